"""The structure choice's reporting: one line per informative axis where eTS is behind ARX
(×1.02) or no-change, with the likely reason; nothing where it is not."""

from __future__ import annotations

from etsid.ident.structure import behind_lines, fallbacks


def _outputs(ets: float, arx: float, persist: float, informative: bool = True,
             std: float = 0.3) -> dict:
    return {"p": {"validation": {"one_step": {"rmse": ets, "informative": informative,
                                              "signal_std": std}},
                  "arx": {"validation": {"one_step": {"rmse": arx}}},
                  "persistence": {"validation": {"rmse": persist}}}}


def test_behind_arx_says_which_and_why() -> None:
    lines = behind_lines(_outputs(0.0139, 0.0121, 0.048), rules=3, excited_learn_s=40.0,
                         rate_hz=50.0, n_params=39)
    assert len(lines) == 1
    assert lines[0].startswith("warning: p: eTS validation one-step RMSE 0.0139 is behind "
                               "ARX 0.0121 (1.15×)")
    assert "one regime only: 3 rules" in lines[0]


def test_the_reasons_in_their_order() -> None:
    few = behind_lines(_outputs(0.02, 0.01, 0.05), 1, 5.0, 50.0, 39)
    assert "too little excitation: 5.0 s" in few[0]
    still = behind_lines(_outputs(0.02, 0.01, 0.05, std=0.07), 1, 40.0, 50.0, 39)
    assert "too little excitation in the validation part" in still[0]
    floor = behind_lines(_outputs(0.0105, 0.0100, 0.0110), 1, 40.0, 50.0, 39)
    assert "noise floor" in floor[0]
    behind_persist = behind_lines(_outputs(0.0112, 0.0111, 0.0110), 1, 40.0, 50.0, 39)
    assert "no-change 0.011" in behind_persist[0] and "ARX" not in behind_persist[0].split(
        "likely")[0].split("behind")[1]


def test_no_line_when_level_or_not_informative() -> None:
    assert behind_lines(_outputs(0.0122, 0.0121, 0.048), 1, 40.0, 50.0, 39) == []
    assert behind_lines(_outputs(0.02, 0.01, 0.005, informative=False), 1, 40.0, 50.0,
                        39) == []


def test_the_better_baseline_is_used_for_an_axis_behind() -> None:
    assert fallbacks(_outputs(0.0139, 0.0121, 0.048)) == {"p": "ARX"}
    assert fallbacks(_outputs(0.0243, 0.0243, 0.0211)) == {"p": "no-change"}
    assert fallbacks(_outputs(0.0122, 0.0121, 0.048)) == {}
    assert fallbacks(_outputs(0.02, 0.01, 0.005, informative=False)) == {}
    line = behind_lines(_outputs(0.0243, 0.0243, 0.0211), 1, 40.0, 50.0, 39)[0]
    assert line.endswith("p falls back to no-change (metrics.json outputs.p.used)")


def test_too_little_data_to_check_keeps_the_simplest() -> None:
    """A 4 s flight with altitude (the scheduled candidate exists): its learning part is too
    short for the inner split, so nothing can be checked and one rule (ARX) is kept and said
    to be unchecked (before issue 41 the scheduled model was kept)."""
    import numpy as np

    from etsid.ident import IdentConfig, identify
    from etsid.ident.synthetic import rate_table

    table = rate_table(1000, seed=2, segments=1)
    table["alt"] = 0.3 + 0.2 * np.sin(np.arange(len(table)) / 200.0)
    run = identify(table, IdentConfig(segments="all"))
    note = next(n for n in run.config["model"]["notes"] if n.startswith("structure: "))
    assert note.startswith("structure: one rule (ARX), the simplest, unchecked")
    assert run.metrics["rules"]["frozen"] == 1
    assert run.config["parameters"]["max_rules"] == 1


def test_the_validation_table_goes_on_from_the_inner_models() -> None:
    """Each candidate of the validation table is the structure choice's online model
    learnt on to the validation start: the same bits as one pass from the first row (with
    the ranges of the rows before the inner validation), the stored model left as it was;
    rows that differ from the ones it learnt are learnt again from the first row."""
    import numpy as np

    from etsid.ident import IdentConfig
    from etsid.ident.checks import split_excited
    from etsid.ident.model_choice import choose_model
    from etsid.ident.regressors import build
    from etsid.ident.resample import decimate
    from etsid.ident.structure import (
        _learnt_to,
        candidate,
        choose_structure,
        merged,
        train,
        untrained,
    )
    from etsid.ident.synthetic import rate_table

    table = rate_table(9000, seed=4, segments=1)
    table["alt"] = 0.3 + 0.5 * (1.0 + np.sin(np.arange(len(table)) / 700.0))
    table = decimate(table, 50.0)
    config = IdentConfig(segments="all")
    spec = choose_model(table, config).spec
    assert spec.antecedent  # rules on the altitude: the scheduled candidate is there
    reg = build(table, spec)
    excited = np.ones(len(reg.X), dtype=bool)
    split = split_excited(excited, 0.3)
    choice = choose_structure(reg, spec, config, excited, split, len(table))
    assert set(choice.online) == {"arx", "unscheduled", "scheduled"}
    for name, (stored, t_learnt) in choice.online.items():
        c_spec, c_config = candidate(name, spec, config)
        c_reg = build(table, c_spec)
        inner = len(t_learnt)
        assert 0 < inner < split
        before = stored.to_dict()
        S = c_reg.S[:split] if c_spec.antecedent else None
        onepass = untrained(c_reg, c_spec, c_config, inner)
        onepass.run(c_reg.X[:split], c_reg.Y[:split], S)
        onepass = merged(onepass, c_reg, c_spec, c_config, split)
        goes_on = _learnt_to(name, c_reg, c_spec, c_config, split, choice.online)
        Sv = c_reg.S[split:] if c_spec.antecedent else None
        assert np.array_equal(goes_on.predict(c_reg.X[split:], Sv),
                              onepass.predict(c_reg.X[split:], Sv))
        assert stored.to_dict() == before
        moved = {name: (stored, t_learnt + 1.0)}  # not the rows it learnt
        again = _learnt_to(name, c_reg, c_spec, c_config, split, moved)
        fresh = train(c_reg, c_spec, c_config, split)
        assert np.array_equal(again.predict(c_reg.X[split:], Sv),
                              fresh.predict(c_reg.X[split:], Sv))
