"""Library warnings during a command (issue 20): never a multi-line Python warning above
the error; one `tactile: warning:` line each after success, the error line's context on
failure."""

from __future__ import annotations

import warnings

import pytest

from tactile_cli.cli._errors import run_guarded
from tactile_cli.errors import InputError


def _body(fail: bool):
    def body():
        warnings.warn("invalid value\nencountered in divide", RuntimeWarning, stacklevel=1)
        warnings.warn("invalid value\nencountered in divide", RuntimeWarning, stacklevel=1)
        if fail:
            raise InputError("bad row", path="x.csv", where="line 3")
        return 7
    return body


def test_warnings_after_success_are_one_line_each_after_the_output(capsys):
    with warnings.catch_warnings():
        warnings.simplefilter("always")  # as a user's interpreter shows them
        assert run_guarded(_body(False)) == 7
    err = capsys.readouterr().err
    assert err == "tactile: warning: RuntimeWarning: invalid value encountered in divide\n"


def test_a_warning_before_an_error_goes_into_the_one_error_line(capsys):
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        with pytest.raises(SystemExit) as exit_info:
            run_guarded(_body(True))
    assert exit_info.value.code == 2
    assert capsys.readouterr().err.splitlines() == [
        "tactile: error: x.csv, line 3: bad row (after the warning 'RuntimeWarning: invalid "
        "value encountered in divide')"]
