from tactile_cli.cli import main

main()
