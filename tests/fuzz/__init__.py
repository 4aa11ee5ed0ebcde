"""Seeded fuzzing of every command on damaged inputs (issue 20): see corpus.py and runner.py."""
