"""How the CLI prints library errors: the library names Python arguments (`overwrite=True`),
the command line its flags (--overwrite), through each command's ``FLAGS`` table."""

from __future__ import annotations

import sys

import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.cli._errors import COMMON_FLAGS, run_guarded, seconds_as_ms, to_flags
from tactile_cli.errors import InputError
from tactile_cli.samples import write_events_csv
from tactile_cli.store import StoreWriter

from ..factories.fos_counts import write_counts_file
from .test_cli_basics import COMMANDS

runner = CliRunner()
TABLE = {**COMMON_FLAGS, "bin_s": ("--bin-ms", seconds_as_ms), "regions": "--regions",
         "seed": "--seed", "data_paths": "--data FILE"}


@pytest.mark.parametrize(("library", "cli"), [
    ("output exists; pass `overwrite=True` to replace it",
     "output exists; pass --overwrite to replace it"),
    ("pass e.g. `bin_s=0.02`", "pass e.g. --bin-ms 20"),
    ("bins are 20 ms; pass `bin_s=0.02`, not `bin_s=0.01`", "bins are 20 ms; pass --bin-ms 20, "
     "not --bin-ms 10"),
    ("or pass `regions='detect'`", "or pass --regions detect"),
    ("`seed` (=-1) must be a non-negative integer", "--seed (=-1) must be a non-negative integer"),
    ("`bin_s` (=1.5e-06) must be whole microseconds", "--bin-ms (=0.0015) must be whole "
     "microseconds"),
    ("`bin_s=auto` is not a number", "--bin-ms auto is not a number"),
    ("no data files; give `data_paths`", "no data files; give --data FILE"),
])
def test_to_flags_spells_argument_references_as_flags(library, cli):
    assert to_flags(library, TABLE) == cli


@pytest.mark.parametrize("message", [
    "`threshold` must be in [0, 1]",  # not in this command's table
    "unknown key `centroid.polarty`",  # a config key
    "an `optics:` section; `rois[0].x1` must be a whole number of px",
    "run `tactile evaluate RUN --data FILE` first",  # a command to run
    "seed=2 and --seed outside backticks are prose",
])
def test_to_flags_leaves_other_backticked_words_alone(message):
    assert to_flags(message, TABLE) == message


def test_every_flag_table_names_options_of_its_command():
    tables = 0
    for path, command in COMMANDS:
        if command.callback is None:
            continue
        flags = getattr(sys.modules[command.callback.__module__], "FLAGS", None)
        if flags is None:
            continue
        tables += 1
        options = {o for p in command.params if p.param_type_name == "option" for o in p.opts}
        for argument, spelling in {**COMMON_FLAGS, **flags}.items():
            spelling = spelling if isinstance(spelling, str) else spelling[0]
            for word in spelling.split():
                if word.startswith("--") and argument not in COMMON_FLAGS:
                    assert word in options, (path, argument, word)
    assert tables >= 12


def test_library_says_overwrite_true_and_the_cli_says_overwrite(tmp_path):
    out = tmp_path / "o.h5"
    out.write_bytes(b"earlier")
    with pytest.raises(InputError) as exc:
        StoreWriter(out)
    assert str(exc.value) == f"{out}: output exists; pass `overwrite=True` to replace it"
    assert "--" not in str(exc.value)

    src = tmp_path / "rec.csv"
    write_events_csv(src, 20, width=32, height=24, seed=1)
    result = runner.invoke(app, ["ingest", str(src), "--width", "32", "--height", "24",
                                 "--out", str(out), "--no-progress"])
    assert result.exit_code == 2
    assert result.stderr == (f"tactile: error: {out}: output exists; pass --overwrite to "
                             "replace it\n")
    assert out.read_bytes() == b"earlier"


def test_fit_fos_spells_bin_s_as_bin_ms_and_regions_as_its_flag(tmp_path):
    counts = tmp_path / "c.h5"
    write_counts_file(counts, n_trials=1, seed=2)
    result = runner.invoke(app, ["fit-fos", str(counts), "--bin-ms", "10"])
    assert result.exit_code == 2
    assert result.stderr == (f"tactile: error: {counts}, /trials/trial_00/signals/event_counts: "
                             "the stream's bins are 20 ms, not the 10 ms asked for; "
                             "pass --bin-ms 20\n")
    bare = tmp_path / "b.h5"
    write_counts_file(bare, n_trials=1, seed=2, annotate=False)
    result = runner.invoke(app, ["fit-fos", str(bare), "--regions", "annotations"])
    assert result.exit_code == 2
    assert result.stderr == (f"tactile: error: {bare}, /trials/trial_00: no 'press' and 'slip' "
                             "annotations; add them at ingest (`tactile ingest --annotations "
                             "FILE`) or pass --regions detect\n")


def test_run_guarded_spells_overwrite_everywhere_and_other_names_from_the_table(capsys):
    def body():
        raise InputError("`threshold` (=2) must be in [0, 1]; or pass `overwrite=True`")

    with pytest.raises(SystemExit) as exit_:
        run_guarded(body)
    assert exit_.value.code == 2
    assert capsys.readouterr().err == ("tactile: error: `threshold` (=2) must be in [0, 1]; or "
                                       "pass --overwrite\n")
    with pytest.raises(SystemExit):
        run_guarded(body, flags={"threshold": "--threshold"})
    assert capsys.readouterr().err == ("tactile: error: --threshold (=2) must be in [0, 1]; or "
                                       "pass --overwrite\n")


def test_an_argument_named_like_an_option_is_spelt_without_a_table_entry():
    """``spell`` reads the running command's options: `max_steps` -> --max-steps, a switch
    as its flag, a name the command lacks left as the library wrote it, and a FLAGS entry
    (a library name that differs from the option's) still wins."""
    import typer

    from tactile_cli.cli._errors import spell

    demo = typer.Typer()

    @demo.command()
    def go(max_steps: int = 3, dry_run: bool = typer.Option(False, "--dry-run"),
           bin_ms: float = 20.0) -> None:
        typer.echo(spell("`max_steps=0` is too few; `dry_run=True` or `bin_s=0.02`; "
                         "`unknown=1` stays", {"bin_s": ("--bin-ms", seconds_as_ms)}))

    res = runner.invoke(demo, [])
    assert res.exit_code == 0, res.output
    assert res.output.strip() == ("--max-steps 0 is too few; --dry-run or --bin-ms 20; "
                                  "`unknown=1` stays")
    assert spell("`max_steps=0`") == "`max_steps=0`"  # outside a command: no options known
