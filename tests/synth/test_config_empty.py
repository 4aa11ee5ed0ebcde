"""Issue 20: an empty synth config is a truncated file, not a request for the defaults."""

from __future__ import annotations

import pytest

from tactile_cli.errors import InputError
from tactile_cli.synth.config import load_synth_config


@pytest.mark.parametrize("text", ["", "\n  \n", "# only a comment\n"])
def test_empty_synth_config_is_an_error_naming_the_file(tmp_path, text):
    path = tmp_path / "synth.yaml"
    path.write_text(text)
    with pytest.raises(InputError) as exc:
        load_synth_config(path)
    assert str(path) in str(exc.value) and "empty config" in str(exc.value)
    assert "\n" not in str(exc.value)
