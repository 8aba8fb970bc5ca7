"""The rut walls' passive resistance (soil_body_contact's ``rut_walls``, body_kernels.rut_wall) against Rankine's
closed form, and what it does for a shape gait.

Reference (Rankine 1857; any soil-mechanics text, e.g. Terzaghi, Theoretical Soil Mechanics, 1943, ch. on earth
pressure): a wall of depth z pushed into a soil of unit weight γ, cohesion c and friction angle φ meets the
passive force per unit length ½ γ z² K_p + 2 c z √K_p, K_p = tan²(45° + φ/2). For the test's cylinder pressed
PEN into sand (its deepest sinkage), sliding sideways at v ≫ v_ε, the walls add L_c (…) against the motion, L_c
the contact's axial extent: the cylinder's length to within a cell at each end. Sliding along its axis, they add
nothing.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import test_body_soil as body

RHO, G = 1600.0, 9.81           # kg/m³ (dry sand), m/s²


def rankine(z, soil=body.SAND):
    kp = math.tan(math.pi / 4 + math.radians(soil.friction_angle) / 2) ** 2
    return 0.5 * RHO * G * z * z * kp + 2.0 * soil.cohesion * z * math.sqrt(kp), kp


def walls():
    return (RHO * G, rankine(1.0)[1])


def test_a_link_pushed_sideways_meets_rankines_passive_force():
    per_m, _ = rankine(body.PEN)
    off, _ = body.kernel(v=(0.0, 0.5, 0.0))
    on, per_link = body.kernel(v=(0.0, 0.5, 0.0), walls=walls())
    extra = on[:3] - off[:3]
    # the contact's axial extent is the cylinder's L within a cell at each end (the node lattice); the depth
    # is the deepest node's sinkage, PEN within the lattice's sag Δ²/R
    lo = rankine(body.PEN - body.CELL ** 2 / body.R)[0] * (body.L - body.CELL)
    hi = per_m * (body.L + 2 * body.CELL)
    assert lo <= -extra[1] <= hi                               # against the motion (+y)
    assert abs(extra[0]) < 1e-12 * abs(extra[1]) and abs(extra[2]) < 1e-12 * abs(extra[1])
    assert per_link[body.L_NORMAL] == body.kernel(v=(0.0, 0.5, 0.0))[1][body.L_NORMAL]   # the pressure unchanged


def test_sliding_along_the_axis_the_walls_add_nothing():
    off, _ = body.kernel(v=(0.5, 0.0, 0.0))
    on, _ = body.kernel(v=(0.5, 0.0, 0.0), walls=walls())
    assert np.abs(on - off).max() < 1e-9 * np.abs(off).max()


def test_at_rest_the_walls_resist_like_a_stiff_viscous_law_and_the_jacobian_says_so():
    """Near rest (|v_a| ≪ v_ε) the force is −P v_a / v_ε: the declared ∂F/∂v against central differences."""
    v_eps = 0.01
    V = np.array([0.0, 1e-4, 0.0, 0.0, 0.0, 0.0])
    args = dict(v_eps=v_eps, walls=walls(), cell=0.004)
    _, _, d_twist, _ = body.kernel(v=V, blocks=True, **args)
    _, _, d_off, _ = body.kernel(v=V, blocks=True, **{**args, "walls": (0.0, 0.0)})
    h = 1e-7
    dv = np.zeros(6)
    dv[1] = h
    fd = (body.kernel(v=V + dv, **args)[0] - body.kernel(v=V - dv, **args)[0]) / (2 * h)
    fd_off = (body.kernel(v=V + dv, **{**args, "walls": (0.0, 0.0)})[0]
              - body.kernel(v=V - dv, **{**args, "walls": (0.0, 0.0)})[0]) / (2 * h)
    wall_slope = fd - fd_off
    assert np.abs((d_twist - d_off)[:, 1] - wall_slope).max() <= 1e-5 * np.abs(wall_slope).max()
    assert wall_slope[1] < 0.0


def test_rut_walls_without_a_density_are_refused_naming_the_key(tmp_path):
    from snakesim.framework.errors import SnakesimError
    from snakesim.framework.session import load_session

    s = load_session("mini-eels-sand-crawl", overrides=["rut_walls=true", f"terrain={_without_density(tmp_path)}"],
                     sim_overrides={"duration": 0.02})
    with pytest.raises(SnakesimError) as e:
        s.run()
    msg = str(e.value)
    assert "no-density.yaml" in msg and "soil.density" in msg and "rut_walls" in msg


def _without_density(tmp_path):
    from pathlib import Path

    terrains = Path(__file__).parents[2] / "terrains"
    soil = (terrains / "soils" / "dry-sand-lll.yaml").read_text()
    (tmp_path / "soils").mkdir()
    (tmp_path / "soils" / "sand.yaml").write_text(
        "\n".join(ln for ln in soil.splitlines() if not ln.startswith("density:")) + "\n")
    field = (terrains / "sand-field.yaml").read_text()
    assert "soils/dry-sand-lll.yaml" in field
    path = tmp_path / "no-density.yaml"
    path.write_text(field.replace("soils/dry-sand-lll.yaml", "soils/sand.yaml"))
    return path


@pytest.mark.slow
def test_lateral_undulation_on_sand_goes_forward_with_the_rut_walls_and_not_without():
    """Lateral undulation propels against its travelling wave only where the body meets more resistance across
    than along itself (Gray & Lissmann 1950; isotropic Coulomb friction drives it backwards or nowhere).
    Mohr–Coulomb shear alone (skin 1, 1) is isotropic: the crawl does not go against the wave; the rut walls
    resist sideways motion only: it does, as with the fitted ``across`` factor. The wave's direction is read
    from the recorded joints (the phase lag from one wave joint to the next), not from the gait's parameters."""
    from snakesim.framework.session import load_session

    def crawl(overrides):
        s = load_session("mini-eels-sand-crawl", overrides=overrides, sim_overrides={"duration": 6.0})
        r = s.run()
        assert r.summary["outcome"] == "success"
        # each wave joint's phase at the gait's frequency: the next one lagging means the wave runs first → last
        q, t = r["robot.joint_q"], r["t"]
        names = s.plan.components["robot"].robot.joints
        c = [np.sum(q[:, names.index(f"bend_0{k}")] * np.exp(-2j * np.pi * 0.5 * t)) for k in (1, 3, 5, 7, 9)]
        lag = np.angle(np.array(c[1:]) / np.array(c[:-1]))
        assert np.all(np.abs(np.abs(lag) - np.pi / 2) < 0.5)       # a travelling wave, a quarter period a joint
        poses = r["robot.link_poses"].reshape(len(t), -1, 7)
        wave = poses[0, -1, :2] - poses[0, 0, :2]         # first link → last link
        wave *= 1.0 if np.all(lag < 0) else -1.0
        com = r["robot.com"]
        return -(com[-1, :2] - com[0, :2]) @ (wave / np.linalg.norm(wave))     # progress against the wave, m

    assert crawl([]) > 0.02                         # the fitted factor: the reference gait crawls (2 cm in 6 s)
    assert crawl(["skin.across=1.0"]) < 0.0         # isotropic shear: with the wave, backwards
    assert crawl(["skin.across=1.0", "rut_walls=true"]) > 0.02     # the walls' anisotropy: against it
