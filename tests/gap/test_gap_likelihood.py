"""The likelihood criterion's parts against known answers: the AR noise model, the blocked
folds, the pseudo-BMA+ weights, the choice rule and the calibration file."""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np
import pytest

from etsid.errors import GapError
from etsid.gap.calibration import Calibration, calibration_dict, load_calibration
from etsid.gap.criterion import (
    Evaluated,
    LikelihoodScorer,
    choose,
    make_folds,
    mismatched,
    offset_limit,
    pseudo_bma,
    significant,
)
from etsid.gap.fitting import Fit, Scorer
from etsid.gap.noise import decimation, fit_ar, fit_noise, offset_z2


def _ar2(n: int, a1: float, a2: float, sd: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    e = np.zeros(n)
    w = rng.normal(0.0, sd, n)
    for t in range(2, n):
        e[t] = a1 * e[t - 1] + a2 * e[t - 2] + w[t]
    return e


def test_ar_fit_recovers_a_known_process_and_whitens_it():
    e = _ar2(20000, 1.2, -0.5, 0.3, 1)
    mask = np.ones(e.size, dtype=bool)
    coef, sd = fit_ar(e, mask)
    assert coef.size >= 2
    assert coef[0] == pytest.approx(1.2, abs=0.03)
    assert coef[1] == pytest.approx(-0.5, abs=0.03)
    assert sd == pytest.approx(0.3, rel=0.03)
    noise = fit_noise({"p": e}, mask, {"p": 0.0}, fs=100.0, cutoffs={"p": 100.0})
    innov = noise.channels["p"].whiten(e)
    ok = np.isfinite(innov)
    lag1 = np.corrcoef(innov[ok][1:], innov[ok][:-1])[0, 1]
    assert abs(lag1) < 0.03  # white, while the raw process is strongly correlated
    assert np.corrcoef(e[1:], e[:-1])[0, 1] > 0.5


def test_real_noise_raises_the_innovation_floor():
    e = _ar2(5000, 0.5, 0.0, 1.0, 2)
    mask = np.ones(e.size, dtype=bool)
    rms = float(np.sqrt(np.mean(e**2)))
    quiet = fit_noise({"p": e}, mask, {"p": 0.5 * rms}, 100.0, {"p": 100.0})
    loud = fit_noise({"p": e}, mask, {"p": 3.0 * rms}, 100.0, {"p": 100.0})
    assert quiet.channels["p"].sigma == pytest.approx(1.0, rel=0.05)
    assert loud.channels["p"].sigma == pytest.approx(3.0 * quiet.channels["p"].sigma, rel=1e-9)


def test_real_sensor_noise_enters_the_innovation_floor_directly():
    # SIM's residual: AR(1) with innovations 0.1; REAL's own sensor noise through the same
    # processing: white, deviation 0.5 -> whitened by SIM's filter it keeps about
    # 0.5 * sqrt(1 + a^2), and that is the floor, not SIM's 0.1
    e = _ar2(20000, 0.6, 0.0, 0.1, 3)
    mask = np.ones(e.size, dtype=bool)
    noise_series = np.random.default_rng(4).normal(0.0, 0.5, 20000)
    model = fit_noise({"p": e}, mask, {"p": 0.0}, 100.0, {"p": 100.0}, {"p": noise_series})
    assert model.channels["p"].sigma == pytest.approx(0.5 * np.sqrt(1 + 0.6**2), rel=0.05)
    bare = fit_noise({"p": e}, mask, {"p": 0.0}, 100.0, {"p": 100.0})
    assert bare.channels["p"].sigma == pytest.approx(0.1, rel=0.05)


def _sensor_flight(rng: np.random.Generator, offsets: np.ndarray, n: int = 6000
                   ) -> dict[str, np.ndarray]:
    return {c: b + rng.normal(0.0, 0.002, n) for c, b in
            zip(("gyro_p", "gyro_q", "gyro_r"), offsets, strict=True)}


def test_sensor_offsets_are_judged_against_the_spread_sim_shows():
    # every flight (SIM and REAL) draws a per-axis offset of spread 0.005; REAL's offsets of
    # that spread pass the F(1, 3) test at 1 % about 99 % of the time, a 0.2 offset never
    rng = np.random.default_rng(5)
    mask = np.ones(6000, dtype=bool)
    cal = Calibration(2.0, 0.1, 0.1, 0.01, {})
    flagged, n = 0, 300
    for _ in range(n):
        sim = _sensor_flight(rng, rng.normal(0.0, 0.005, 3))
        real = _sensor_flight(rng, rng.normal(0.0, 0.005, 3))
        model = fit_noise(sim, mask, dict.fromkeys(sim, 0.0), 100.0, dict.fromkeys(sim, 100.0),
                          real_residuals=real, real_mask=mask)
        offs = {c: (offset_z2(model.channels[c], model.channels[c].whiten(real[c]), mask), 3)
                for c in real}
        flagged += bool(mismatched(dict.fromkeys(real, 1.0), offs, cal))
    assert flagged / n < 0.03
    ch = model.channels["gyro_p"]
    assert ch.offset_dof == 3 and ch.offset_sd > 0.0
    assert ch.floor_var > ch.sigma ** 2  # an offset within the spread is no evidence
    biased = dict(real, gyro_q=real["gyro_q"] + 0.2)
    offs = {c: (offset_z2(ch, model.channels[c].whiten(biased[c]), mask), 3) for c in biased}
    assert mismatched(dict.fromkeys(biased, 1.0), offs, cal) == ["gyro_q"]
    assert offset_limit(3, 6, 0.01) > offset_limit(30, 6, 0.01) > 1.0


class _OffsetModel(Scorer):
    """A nominal model that predicts a constant per channel: ``mods`` maps channel →
    offset (None: zero), so that a fitted offset is the whole model change."""

    def prediction(self, mods=None, channels=None):
        n = next(iter(self.measured.values())).size
        return {c: np.full(n, (mods or {}).get(c, 0.0)) for c in channels or self.measured}


@dataclass(frozen=True)
class _Bias:
    channels: tuple[str, ...]


def test_a_fitted_offset_gains_at_most_what_the_flight_offset_test_says():
    # SIM and REAL each carry their own gyro-vs-attitude offsets of spread 0.005; REAL's
    # within that spread must gain next to nothing, a 0.2 offset on q exactly half its
    # offset statistic (the likelihood ratio against the random-offset null)
    rng = np.random.default_rng(7)
    n = 6000
    mask = np.ones(n, dtype=bool)
    sim = _sensor_flight(rng, rng.normal(0.0, 0.005, 3), n)
    real = _sensor_flight(rng, np.array([0.004, -0.003, 0.005]), n)
    real["gyro_q"] = real["gyro_q"] + 0.2
    noise = fit_noise(sim, mask, dict.fromkeys(sim, 0.0), 100.0, dict.fromkeys(sim, 100.0),
                      real_residuals=real, real_mask=mask)
    folds = make_folds(mask, fs=100.0)
    ls = LikelihoodScorer(_OffsetModel(None, real, dict.fromkeys(real, 0.002)), noise, folds)
    bias = (_Bias(tuple(real)),)
    fits = [Fit(bias, np.zeros(3), np.zeros(3),
                {c: float(np.mean(v[fold])) for c, v in real.items()})
            for fold in folds.fit]
    _, _, by_channel = ls.gain(fits)
    for c in ("gyro_p", "gyro_r"):
        half_z2 = 0.5 * offset_z2(noise.channels[c], noise.channels[c].whiten(real[c]), mask)
        assert by_channel[c][0] <= half_z2 + 1e-9
        assert half_z2 < 0.5 * offset_limit(3, 3, 0.01)  # within the spread: no mismatch
    half_z2_q = 0.5 * offset_z2(noise.channels["gyro_q"],
                                noise.channels["gyro_q"].whiten(real["gyro_q"]), mask)
    assert by_channel["gyro_q"][0] == pytest.approx(half_z2_q, rel=1e-3)  # scored samples only
    assert half_z2_q > 100.0
    ls.offset_evidence = {}  # the plain likelihood: the small offsets gain with every sample
    _, _, plain = ls.gain(fits)
    assert plain["gyro_p"][0] > 100 * max(by_channel["gyro_p"][0], 1.0)


def test_decimation_reads_a_slow_channel_sparsely():
    assert decimation(100.0, 8.0) == 3
    assert decimation(100.0, 0.5) == 50
    assert decimation(10.0, 8.0) == 1


def test_folds_are_disjoint_blocks_that_cover_the_evidence():
    mask = np.zeros(5000, dtype=bool)
    mask[100:2100] = True
    mask[2500:4900] = True
    folds = make_folds(mask, fs=100.0, n_folds=2, block_s=4.0, gap_s=0.5)
    a, b = folds.score
    assert not np.any(a & b)
    assert not np.any((a | b) & ~mask)
    assert np.all(folds.fit[0] == (mask & ~a))
    assert abs(int(a.sum()) - int(b.sum())) <= 400
    assert folds.n_blocks == 11  # 5 + 6 blocks of 4 s (the last one short)
    assert set(np.unique(folds.block[a | b])) == set(range(folds.n_blocks))


def _ev(name: str, blocks: list[float], n: int = 1000, refused: str = "") -> Evaluated:
    return Evaluated(name, (), [], np.array(blocks, dtype=float), n, refused=refused)


def test_look_alikes_share_their_weight_and_a_clear_winner_takes_it():
    same = [5.0, 7.0, 6.0, 8.0, 5.5, 6.5]
    w = pseudo_bma([_ev("thrust_scale", same), _ev("mass", same)])
    assert w[0] == pytest.approx(0.5, abs=1e-9) and w[1] == pytest.approx(0.5, abs=1e-9)
    assert w[2] < 1e-6  # the null
    w = pseudo_bma([_ev("time_delay", [50.0] * 6), _ev("motor_lag", [10.0] * 6)])
    assert w[0] > 0.999


def test_choose_names_above_the_threshold_and_pairs_only_past_their_own():
    cal = Calibration(4.0, 0.01, 0.05, 0.01, {})
    lead = _ev("thrust_scale", [100.0], n=1000)  # 0.1 per sample
    weak = _ev("gyro_bias", [5.0], n=1000)
    pair_small = _ev("thrust_scale+gyro_bias", [130.0], n=1000)  # +0.03 per sample
    assert choose([lead, weak, pair_small], cal) == "thrust_scale"
    pair_big = _ev("thrust_scale+gyro_bias", [200.0], n=1000)  # +0.1
    assert choose([lead, weak, pair_big], cal) == "thrust_scale+gyro_bias"
    assert choose([_ev("thrust_scale", [5.0], n=1000)], cal) is None
    refused = _ev("thrust_scale", [100.0], n=1000, refused="at bound")
    assert choose([refused, weak], cal) is None
    rows = [{"name": "thrust_scale", "gain": 100.0, "per_sample": 0.1, "n_scored": 1000,
             "refused": ""}]
    assert choose(rows, cal) == "thrust_scale"


def test_a_sensor_offset_is_named_by_the_offset_law_not_by_its_samples():
    # a gyro bias's gain is per flight (at most half REAL's offset statistic): it passes
    # where half the F(1, 3) limit at the rate is exceeded on a channel, whatever its gain
    # per sample; below that limit it does not, however many samples the flight has
    cal = Calibration(4.0, 0.05, 0.05, 0.01, {})
    offset = {c: (0.0, 3) for c in ("gyro_p", "gyro_q", "gyro_r")}
    half_limit = 0.5 * offset_limit(3, 3, 0.01)
    strong = _ev("gyro_bias", [half_limit + 1.0], n=20000)  # 0.003 nats per sample
    strong.by_channel = {"gyro_q": (half_limit + 1.0, 20000)}
    weak = _ev("gyro_bias", [half_limit - 1.0], n=20000)
    weak.by_channel = {"gyro_q": (half_limit - 1.0, 20000)}
    assert choose([strong], cal, offset=offset) == "gyro_bias"
    assert choose([weak], cal, offset=offset) is None
    assert choose([strong], cal) is None  # without the offset law: the per-sample rule
    row = {"name": "gyro_bias", "gain": half_limit + 1.0, "per_sample": 0.003,
           "n_scored": 20000, "refused": "", "by_channel": {"gyro_q": [half_limit + 1.0, 9]}}
    assert choose([row], cal, offset={c: [0.0, 3] for c in offset}) == "gyro_bias"


def test_a_gain_within_its_block_spread_is_not_named():
    """Above the size threshold but not beyond chance over the blocks: not named."""
    cal = Calibration(4.0, 0.01, 0.05, 0.01, {})
    steady = _ev("thrust_scale", [25.0, 25.0, 25.0, 25.0], n=1000)  # 0.1 per sample
    erratic = _ev("thrust_scale", [400.0, -300.0, 250.0, -250.0], n=1000)  # 0.1 too
    assert significant(steady.gain, steady.gain_se, 16, 0.01)
    assert not significant(erratic.gain, erratic.gain_se, 16, 0.01)
    assert choose([steady], cal) == "thrust_scale"
    assert choose([erratic], cal) is None
    row = {"name": "thrust_scale", "gain": 100.0, "per_sample": 0.1, "n_scored": 1000,
           "gain_se": 80.0, "refused": ""}
    assert choose([row], cal) is None  # recorded rows decide the same way
    assert choose([{**row, "gain_se": 20.0}], cal) == "thrust_scale"


def test_a_second_effect_is_sought_only_while_a_channel_is_left():
    """A pair that passes its own threshold is not named when REAL, held out under the
    first effect, has no channel left beyond its floor; it is when one is left."""
    cal = Calibration(2.0, 0.01, 0.05, 0.01, {})
    lead = _ev("thrust_scale", [100.0], n=1000)
    pair = _ev("thrust_scale+gyro_bias", [200.0], n=1000)  # +0.1 per sample
    done = {"name": "thrust_scale", "ratio": {"az": 1.1, "p": 1.3}, "offset": {}}
    left = {"name": "thrust_scale", "ratio": {"az": 1.1, "p": 3.5}, "offset": {}}
    assert choose([lead, pair], cal, done) == "thrust_scale"
    assert choose([lead, pair], cal, left) == "thrust_scale+gyro_bias"
    noisy = {"name": "thrust_scale+gyro_bias", "gain": 200.0, "per_sample": 0.2,
             "n_scored": 1000, "extra_se": 60.0, "refused": ""}  # +100 ± 60 nats
    row = {"name": "thrust_scale", "gain": 100.0, "per_sample": 0.1, "n_scored": 1000,
           "refused": ""}
    assert choose([row, noisy], cal, left) == "thrust_scale"
    assert choose([row, {**noisy, "extra_se": 20.0}], cal, left) == "thrust_scale+gyro_bias"


def test_pairs_are_sought_on_every_single_tied_with_the_lead():
    """Two singles the blocks cannot order (a motor lag and a delay 7 nats apart over
    blocks that spread by tens) both lead pairs, then the next best above the threshold up
    to PAIR_POOL; one below the threshold does not. The pair built on the second lead is
    named when it explains most."""
    from etsid.gap.criterion import PAIR_POOL, tied_leads

    cal = Calibration(2.0, 0.01, 0.05, 0.01, {})
    lag = _ev("motor_lag", [1400.0, 1300.0, 1500.0, 1318.0], n=1000)
    delay = _ev("time_delay", [1380.0, 1350.0, 1450.0, 1331.0], n=1000)
    far = _ev("inertia_scale", [100.0, 90.0, 110.0, 95.0], n=1000)
    below = _ev("rate_damping", [2.0, 2.0, 2.0, 2.0], n=1000)  # 0.008 per sample
    leads = tied_leads([lag, delay, far, below], cal, 4)
    assert [m.name for m in leads] == ["motor_lag", "time_delay", "inertia_scale"]
    many = [_ev(f"e{i}", [100.0 - i] * 4, n=1000) for i in range(2 * PAIR_POOL)]
    assert len(tied_leads([lag, *many], cal, 9)) == PAIR_POOL
    left = {"name": "motor_lag", "ratio": {"az": 40.0}, "offset": {}}
    lag_pair = _ev("motor_lag+mass", [2450.0] * 4, n=1000)
    delay_pair = _ev("time_delay+thrust_scale", [3400.0] * 4, n=1000)
    for m in (lag_pair, delay_pair):
        m.extra_se = 10.0
    assert choose([lag, delay, far, lag_pair, delay_pair], cal, left) == \
        "time_delay+thrust_scale"


def test_a_pair_on_a_weaker_single_must_beat_the_best_single_by_a_second_effect():
    """A pair built on a single behind the lead adds much over its own base, but is named
    only when it beats the lead by the pair threshold: a look-alike of the lead with a
    small companion is not a better answer than the lead alone."""
    cal = Calibration(2.0, 0.01, 0.05, 0.01, {})
    lag = _ev("motor_lag", [1400.0], n=1000)
    delay = _ev("time_delay", [760.0], n=1000)
    left = {"name": "motor_lag", "ratio": {"p": 40.0}, "offset": {}}
    close = _ev("time_delay+inertia_scale", [1440.0], n=1000)  # +680 over its base, +40 over
    close.extra_se = 10.0
    assert choose([lag, delay, close], cal, left) == "motor_lag"
    clear = _ev("time_delay+inertia_scale", [1500.0], n=1000)  # +100 over the lead
    clear.extra_se = 10.0
    assert choose([lag, delay, clear], cal, left) == "time_delay+inertia_scale"


def test_calibration_file_round_trip_and_bad_file(tmp_path):
    cal = Calibration(5.5, 0.012, 0.04, 0.01, {"generators": ["a", "b"]})
    path = tmp_path / "cal.json"
    path.write_text(json.dumps(calibration_dict(cal)))
    back = load_calibration(str(path))
    assert back == cal
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"schema": "something/1"}))
    with pytest.raises(GapError, match="bad.json: not an etsid gap calibration"):
        load_calibration(str(bad))
    assert load_calibration().gain_per_sample > 0  # the package's own file reads


def test_registry_is_the_authority_on_names():
    from etsid.cli.gap_cmds import gap
    from etsid.gap.candidates import LIBRARY
    from etsid.gap.effects import REGISTRY, docs_table, vocabulary
    from etsid.gap.result import SCHEMA_PATH, schema

    shipped = json.loads(SCHEMA_PATH.read_text())
    enum = shipped["properties"]["effects"]["items"]["properties"]["name"]["enum"]
    assert enum == list(vocabulary())  # the CLI help reads this list (etsid gap --help)
    assert schema()["properties"]["effects"]["items"]["properties"]["name"]["enum"] == list(
        vocabulary())
    assert all(name in gap.help for name in vocabulary())
    # every law of the library belongs to exactly one registered effect, with a prior
    forms = [c for e in REGISTRY for c in e.forms]
    assert len(forms) == len(LIBRARY)
    for e in REGISTRY:
        for c in e.forms:
            assert np.isfinite(e.log_prior(c, np.array([p.x0 for p in c.params])))
        assert f"`{e.name}`" in docs_table()


def test_a_long_flight_is_read_as_evenly_spread_windows():
    from etsid.gap.signals import LEAD_S, MAX_EVIDENCE_S, WINDOW_S, Flight, excerpt

    fs, n = 50.0, 50 * 3600
    t = np.arange(n) / fs
    air = np.ones(n, dtype=bool)
    air[:500] = False
    z = np.zeros((n, 3))
    f = Flight("long.ulg", t, fs, np.zeros((n, 4)), "motors", z, z, z, z, np.zeros(n),
               np.zeros(n), air, {"alt"})
    part, note = excerpt(f)
    assert note is not None and "long.ulg" in note
    assert part.airborne_s == pytest.approx(MAX_EVIDENCE_S, rel=0.03)  # a short last window
    assert part.n == pytest.approx((MAX_EVIDENCE_S / WINDOW_S) * (WINDOW_S + LEAD_S) * fs,
                                   rel=0.03)
    assert np.all(np.diff(part.t) > 0)
    assert part.t[0] < 100.0 and part.t[-1] > 3400.0  # spread over the whole hour
    short, none = excerpt(Flight("short.ulg", t[:5000], fs, np.zeros((5000, 4)), "motors",
                                 z[:5000], z[:5000], z[:5000], z[:5000], np.zeros(5000),
                                 np.zeros(5000), air[:5000], set()))
    assert none is None and short.n == 5000


def test_likelihood_method_names_a_known_thrust_loss_and_writes_valid_gap_json(tmp_path):
    from etsid.gap.result import write_gap_json
    from etsid.gap.run import analyse
    from etsid.sim import simulate

    kw = {"alt_wander": 0.3, "amplitude": 0.4}
    sim = simulate("hover-oge", "quad250", duration=35.0, seed=11, **kw).table
    real = simulate("hover-oge", "quad250", duration=35.0, seed=12,
                    settings={"vehicle.thrust_scale": 0.85}, **kw).table
    data = analyse(sim, real, "sim", "real").data
    assert data["verdict"] == "mismatch"
    named = {e["name"]: e for e in data["effects"]}
    assert "thrust_scale" in named or "mass" in named  # one thrust-to-weight from accelerations
    if "thrust_scale" in named:
        assert named["thrust_scale"]["parameters"]["scale"]["value"] == pytest.approx(0.85,
                                                                                     abs=0.03)
    crit = data["criterion"]
    assert crit["method"] == "likelihood"
    best = max(crit["models"], key=lambda m: m["gain"])
    assert best["per_sample"] > crit["thresholds"]["gain_per_sample"]
    write_gap_json(data, tmp_path)  # validates against the schema


def test_reals_sensor_noise_series_carry_no_offset():
    """The sensor-noise series (white noise at REAL's measured densities through each
    channel's processing) are noise alone: zero mean on every channel, kin_z included,
    where the still synthetic flight's kinematics would otherwise leave gravity."""
    from etsid.gap.floors import sensor_noise
    from etsid.gap.signals import prepare
    from etsid.sim import simulate

    table = simulate(scenario="hover-oge", duration=20.0, seed=3).table
    series = sensor_noise(prepare(table, "real"))
    assert {"kin_z", "gyro_p", "p"} <= set(series)
    for c, y in series.items():
        assert abs(float(np.mean(y))) <= 1e-9 + 1e-6 * float(np.std(y)), c
    assert float(np.std(series["kin_z"])) < 1.0  # m/s²: sensor noise, not gravity
