"""The lumped model of paper 003 (sec. 2.2): analytic single block, eigen-analysis with a
stiff contact, and config errors."""

from __future__ import annotations

import numpy as np
import pytest

from tactile_cli.errors import InputError
from tactile_cli.vibro import (
    ModelConfig,
    assemble,
    frequency_response,
    load_model_config,
    model_spectra,
    natural_frequencies_hz,
)
from tactile_cli.vibro.config import BlockConfig, LinkConfig
from tactile_cli.vibro.model import find_resonances


def _single_block(m=0.01, k=4.0e4, c=0.5) -> ModelConfig:
    return ModelConfig(blocks={"base": BlockConfig(mass_kg=1.0, stiffness_n_m=1e6),
                               "mass": BlockConfig(mass_kg=m, stiffness_n_m=k,
                                                   damping_n_s_m=c, parent="base")},
                       source="base", sensor="mass", contact=[])


def test_single_block_matches_the_analytic_transmissibility_and_resonance():
    m, k, c = 0.01, 4.0e4, 0.5
    model = assemble(_single_block(m, k, c))
    f = np.arange(1.0, 1000.0, 0.05)
    w = 2 * np.pi * f
    analytic = (k + 1j * w * c) / (k - m * w ** 2 + 1j * w * c)
    np.testing.assert_allclose(frequency_response(model, f), analytic, rtol=1e-10)
    f_n = np.sqrt(k / m) / (2 * np.pi)                     # 318.3 Hz
    assert natural_frequencies_hz(model)[0] == pytest.approx(f_n, rel=1e-9)
    peaks = find_resonances(f, np.abs(analytic))
    assert len(peaks) == 1
    zeta = c / (2 * np.sqrt(k * m))
    # transmissibility peaks slightly below f_n: f_n (sqrt(1 + 8 zeta^2) - 1)^0.5 / (2 zeta)
    f_peak = f_n * np.sqrt(np.sqrt(1 + 8 * zeta ** 2) - 1) / (2 * zeta)
    assert peaks[0].f_hz == pytest.approx(f_peak, abs=0.05)
    assert peaks[0].amplitude == pytest.approx(np.abs(analytic).max(), rel=1e-3)


def test_a_stiff_contact_moves_the_resonances_where_eigen_analysis_says():
    base = ModelConfig()
    light = {n: b.model_copy(update={"damping_n_s_m": b.damping_n_s_m * 0.02})
             for n, b in base.blocks.items()}
    cfg = base.model_copy(update={"blocks": light, "contact": [
        LinkConfig(between=("skin_a", "object"), stiffness_n_m=2e5, damping_n_s_m=0.0),
        LinkConfig(between=("object", "skin_s"), stiffness_n_m=2e5, damping_n_s_m=0.0)]})
    spectra = model_spectra(cfg)
    free_nat, contact_nat = spectra.natural_free_hz, spectra.natural_contact_hz
    assert not np.allclose(free_nat, contact_nat, rtol=0.01)
    for found, predicted in ((spectra.resonances_free, free_nat),
                             (spectra.resonances_contact, contact_nat)):
        assert len(found) >= 3
        for r in found:   # every peak sits on a natural frequency of its own state
            assert np.min(np.abs(predicted - r.f_hz) / r.f_hz) < 0.005, (r, predicted)
    # and the contact state's peaks are not the free state's
    moved = [r for r in spectra.resonances_contact
             if np.min(np.abs(free_nat - r.f_hz) / r.f_hz) > 0.02]
    assert moved


def test_contact_stiffness_list_and_errors():
    cfg = ModelConfig()
    a = assemble(cfg, contact=[0.0, 0.0])
    np.testing.assert_array_equal(a.stiffness_n_m, assemble(cfg).stiffness_n_m)
    with pytest.raises(ValueError, match="`contact` gives 1 stiffnesses for 2"):
        assemble(cfg, contact=[1.0])


def test_config_errors_name_the_file_and_key(tmp_path):
    bad = tmp_path / "m.yaml"
    bad.write_text("blocks:\n  a: {mass_kg: 1, stiffness_n_m: 10, colour: red}\n")
    with pytest.raises(InputError, match="colour.*unknown key"):
        load_model_config(bad)
    bad.write_text("blocks:\n  a: {mass_kg: 1, stiffness_n_m: 10}\n"
                   "  b: {mass_kg: 1, stiffness_n_m: 10, parent: nowhere}\nsource: a\n"
                   "sensor: b\ncontact: []\n")
    with pytest.raises(InputError, match="parent 'nowhere' is neither a block"):
        load_model_config(bad)
    assert load_model_config("configs/vibro_model.yaml") == ModelConfig()


def test_blocks_whose_parents_form_a_loop_are_refused(tmp_path):
    """Found by the damaged-input corpus: a loop of parents (a -> b -> a) is no tree hung
    from the ground, and was accepted."""
    bad = tmp_path / "m.yaml"
    bad.write_text("blocks:\n  g: {mass_kg: 1, stiffness_n_m: 10}\n"
                   "  a: {mass_kg: 1, stiffness_n_m: 10, parent: b}\n"
                   "  b: {mass_kg: 1, stiffness_n_m: 10, parent: a}\nsource: g\n"
                   "sensor: a\ncontact: []\n")
    with pytest.raises(InputError, match="parents form a loop") as err:
        load_model_config(bad)
    assert str(bad) in str(err.value) and "\n" not in str(err.value)
