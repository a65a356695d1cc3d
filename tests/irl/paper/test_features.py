import numpy as np
import pytest

from drivestyle.envs import PAPER, Demonstration
from drivestyle.irl.paper.features import (
    FEATURES,
    EventTimes,
    FeatureConfig,
    feature_basis,
    feature_values,
    gauss_legendre_nodes,
)

T = 6.0
t = np.linspace(0, T, 31)
W = {n: w for n, w in zip(FEATURES, FeatureConfig().omega, strict=True)}
L_INIT, L_DES, V_DES = 2.625, 7.875, 30.0


def make_demo(ev_C, tv_C):
    """Demonstration whose EV/TV states follow the given control points (x, vx, ax, y, vy, ay)."""

    def states(C):
        vx, vy = C[:, 1], C[:, 4]
        return np.column_stack([C[:, 0], C[:, 3], np.arctan2(vy, vx), np.hypot(vx, vy)])

    return Demonstration(
        t=t,
        ev=states(ev_C),
        tv=states(tv_C),
        u=np.zeros((t.size - 1, 2)),
        meta={"scenario": PAPER.to_dict()},
    )


def line(x0, v, a, y, vy=0.0):
    return np.column_stack(
        [
            x0 + v * t + 0.5 * a * t**2,
            v + a * t,
            np.full_like(t, a),
            y + vy * t,
            np.full_like(t, vy),
            np.zeros_like(t),
        ]
    )


def feats(C, demo, **cfg):
    basis = feature_basis(demo, FeatureConfig(**cfg))
    return dict(
        zip(FEATURES, feature_values(C[:, :3].ravel(), C[:, 3:].ravel(), basis), strict=True)
    )


def test_gauss_legendre_integrates_polynomials_exactly():
    nodes, w = gauss_legendre_nodes(t, 0.3, 4.55, 5)
    p = np.polynomial.Polynomial(np.arange(1.0, 11.0))  # degree 9
    exact = p.integ()(4.55) - p.integ()(0.3)
    assert np.dot(w, p(nodes)) == pytest.approx(exact, rel=1e-12)
    assert gauss_legendre_nodes(t, 2.0, 2.0, 5)[0].size == 0


def test_constant_speed_straight_line():
    ev = line(80, 25, 0, L_INIT)
    tv = line(60, 25, 0, L_DES)  # constant gap of 20 m
    f = feats(ev, make_demo(ev, tv))
    assert f["ax"] == pytest.approx(0, abs=1e-12) and f["ay"] == pytest.approx(0, abs=1e-12)
    assert f["v"] == pytest.approx((V_DES - 25) ** 2 * T)
    assert f["l"] == pytest.approx((L_DES - L_INIT) * T)
    assert f["il"] == pytest.approx(0, abs=1e-12)  # never leaves its lane: t_turn = T
    assert f["el"] == pytest.approx(W["el"] * (L_DES - L_INIT) * 0.2)
    assert f["tiv"] == pytest.approx(V_DES * T / np.sqrt(20**2 + 1.0))
    assert f["sd"] == f["ed"] == f["id"] == 0.0  # s_e = 4.8 > λ: trigger never fires


def test_constant_acceleration():
    a, v0 = 1.5, 22.0
    ev = line(80, v0, a, L_INIT)
    f = feats(ev, make_demo(ev, line(0, 25, 0, L_DES)))
    assert f["ax"] == pytest.approx(a**2 * T)
    d = V_DES - v0
    assert f["v"] == pytest.approx(d**2 * T - d * a * T**2 + a**2 * T**3 / 3)


def test_quintic_lane_change():
    delta = L_DES - L_INIT
    s = t / T
    P = 10 * s**3 - 15 * s**4 + 6 * s**5
    dP = (30 * s**2 - 60 * s**3 + 30 * s**4) / T
    ddP = (60 * s - 180 * s**2 + 120 * s**3) / T**2
    ev = line(80, 28, 0, 0.0)
    ev[:, 3], ev[:, 4], ev[:, 5] = L_INIT + delta * P, delta * dP, delta * ddP
    f = feats(ev, make_demo(ev, line(0, 28, 0, L_DES)))
    assert f["ay"] == pytest.approx(delta**2 * 120 / (7 * T**3), rel=1e-10)
    assert f["l"] == pytest.approx(delta * T / 2, rel=1e-10)
    # y crosses the lane boundary 5.25 m exactly at t = 3 s (symmetry): f_il = ∫_0^3 (y − l_init)
    assert f["il"] == pytest.approx(W["il"] * delta * T * (10 / 4 / 16 - 3 / 32 + 1 / 64))
    Pi = np.polynomial.Polynomial([1, 0, 0, -10, 15, -6]).integ()  # ∫ (1 − P) ds
    assert f["el"] == pytest.approx(W["el"] * delta * T * (Pi(1.0) - Pi(1 - 0.2 / T)), rel=1e-9)


def test_trigger_and_reactive_features_on_constructed_pair():
    # EV straight in lane 0; TV alongside (same x), drifting towards it at 0.5 m/s.
    # s_e = (Δy/3)² < 1.82  ⇔  Δy < 4.047 m  ⇔  t > 2.41 s: first sample t_trg = 2.6 s.
    ev = line(80, 25, 0, L_INIT)
    tv = line(80, 25, 0, L_DES, vy=-0.5)
    demo = make_demo(ev, tv)
    basis = feature_basis(demo, FeatureConfig())
    assert basis.events.t_trg == pytest.approx(2.6)
    assert basis.events.t_rct_end == pytest.approx(4.6)
    f = feats(ev, demo)
    assert f["sd"] == pytest.approx(W["sd"] * np.exp(-(5.25 - 0.5 * 2.6)))
    assert f["ed"] == pytest.approx(W["ed"] * np.exp(-(5.25 - 0.5 * 4.6)))
    assert f["id"] == pytest.approx(0.0, abs=1e-12)  # the EV does not move laterally
    assert f["tiv"] == pytest.approx(V_DES * T / 1.0)  # Δx = 0: the d_0 = 1 m guard


def test_casadi_and_numpy_features_agree(paper_demo):
    import casadi as ca

    from drivestyle.irl.paper.spline import demo_control_points

    C = demo_control_points(paper_demo)
    basis = feature_basis(paper_demo, FeatureConfig())
    cx, cy = ca.SX.sym("cx", C[:, :3].size), ca.SX.sym("cy", C[:, 3:].size)
    F = ca.Function("f", [cx, cy], [feature_values(cx, cy, basis)])
    np.testing.assert_allclose(
        np.asarray(F(C[:, :3].ravel(), C[:, 3:].ravel())).ravel(),
        feature_values(C[:, :3].ravel(), C[:, 3:].ravel(), basis),
        rtol=1e-12,
    )


def test_bad_feature_config():
    with pytest.raises(ValueError, match="feature_set"):
        FeatureConfig(feature_set="all")
    with pytest.raises(ValueError, match="omega"):
        FeatureConfig(omega=(1.0,) * 6)
    with pytest.raises(ValueError, match="t_rct"):
        FeatureConfig(t_rct=-1.0)


def test_reactive_window_only_when_the_trigger_fired():
    fired = EventTimes(t_end=6.0, t_last=5.8, t_turn=3.0, t_trg=1.2, t_rct_end=2.2)
    assert fired.reactive_window() == (1.2, 2.2)
    silent = EventTimes(t_end=6.0, t_last=5.8, t_turn=3.0, t_trg=None, t_rct_end=None)
    with pytest.raises(ValueError, match="trigger did not fire"):
        silent.reactive_window()
