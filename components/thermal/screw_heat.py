"""Heated screws on ice: one temperature, one melt-in depth and one refreeze-bond hold time per screw.

The paper's field test (EELS 1.5, section 4.3.2): screws heated to 10–40 °C bite into the ice by melting
in at once; a late start leaves them too deep to pull out. This component is the thermal side of that
(equations, units and sources in heat_step.py, ice_properties.py and bond.py)::

    C_s = m_screw c_material                        J/K, per screw
    C_s dT/dt = P_heat + P_slip − q_ice − q_conv − q_rad
    q_ice = G (T − T_m) melting / G (T − T_ice) cold contact / 0 out of contact
    G = g_c A_c (F_n / F_ref)^n_F                   W/K, contact conductance (n_F = 0: constant)
    A_c = L_screw w_c                               m², the contact strip along the screw
    ρ_i (L_f + c_i (T_m − T_ice)) dδ/dt = q_ice / A_c      while melting (Stefan / melting probe)
    δ ← δ exp(−Δs / ℓ_g)                            the groove relaxes only as the screw's centre leaves it
                                                    (Δs = h (v_travel − v_still)⁺, heat_step.py)

g_c (``contact_conductance``, W/(m² K)): the default 20000 is a melt film of 28 µm of water (k_w ≈ 0.56
W/(m K)) — this model's assumption, not a measured value. The load exponent n_F > 0 is the optional
close-contact-melting term (a squeezed film is thinner and conducts better, so the melt rate rises with
the contact force; n_F = 1/4 is the classic close-contact-melting scaling as the brief recalls it, not
checked against a source here); off (0) by default.

Outputs drive the screw contact's law ports (components/contact/contact_law.py), never its code:

    penetration → screw_sinkage     m, δ: the screw sits in its groove
    ev_scale    → screw_ev_scale    1 + k_e min(δ / h_t, 1): thread engagement (h_t the thread depth)
    mu_scale    → screw_mu_scale    mu_base (1 + σ_b A_c / (μ_ref F_n)): the refreeze bond (bond.py)

and the groove drag (groove_drag.py) reads ``penetration`` and the thread depth for the lateral resistance
beyond it. δ is never clamped: past ``max_penetration`` (default the screw radius, where the envelope
would be swallowed and the contact geometry stops meaning anything) the run stops naming the screw.

Integration: a discrete update at the component's ``rate`` (required; 100 Hz in the scenes) with the
linearly implicit Euler step of heat_step.py (unconditionally stable for the linear terms; the radiation
linearised about the step's start). The thermal time constants (C_s / G ≈ 60 s in contact) are far slower than
the mechanics, so a 10 ms sample-and-hold is exact enough; inputs are read at the sample.

Energy ledger (output ``ledger``, J, summed over the screws; heat_step.LEDGER): heater_in, friction_in,
stored = Σ C_s (T − T_0), to_ice_melting (of which latent: ρ_i L_f A_c Δδ, the rest warmed the melted ice),
to_cold_ice, radiated, convected, and residual = in − stored − out, zero to round-off.

Screws: the robot's (metadata order, radius and length from its screw layout) when a multibody provides
the robot; without one, ``screws`` identical screws of ``radius`` and ``length`` (a heated block on ice).

in   heater_power[ns]  W (≥ 0; default 0)         slip_power[ns] W (contact.screw_slip_power; default 0)
     normal_force[ns]  N (contact.screw_normal_force; default 0: out of contact)
     slip_speed[ns]    m/s (contact.screw_slip_speed)   travel_speed[ns] m/s (groove_drag.travel_speed)
     mu_base[ns]       1 (ice_friction.mu_scale; default 1; sampled at the rate, held between samples)
out  temperature[ns] K, penetration[ns] m, ev_scale[ns], mu_scale[ns], bond_time[ns] s, ledger[9] J
     (all from the discrete state: no feedthrough)
uses robot: RobotModel (optional): the screws
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from pydantic import Field

from snakesim.components.multibody.robot_model import RobotModel
from snakesim.framework import Component, Input, Output, Params, Uses

from ..kernel_args import bind
from .heat_kernels import HeatArgs, heat_outputs, heat_update
from .heat_step import LEDGER, constants
from .ice_properties import C_ICE, LATENT_FUSION, RHO_ICE, T_MELT, stefan_energy_density


class ScrewHeatParams(Params):
    mass: float = Field(1.5, gt=0, description="kg per screw (EELS 1.5's screw link, robots/designs.py)")
    specific_heat: float = Field(900.0, gt=0, description="J/(kg K) of the screw material (900: aluminium)")
    initial_temperature: float = Field(293.15, gt=0, description="K, every screw at the start (pre-heated)")
    ice_temperature: float = Field(268.15, gt=0, description="K, the ice far from the screw (T_ice)")
    environment_temperature: float = Field(268.15, gt=0, description="K, air or sky the screws lose heat to")
    melting_point: float = Field(T_MELT, gt=0, description="K, T_m")
    emissivity: float = Field(0.1, ge=0, le=1, description="of the screw surface (0.1: bare metal)")
    convection: float = Field(0.0, ge=0, description="W/(m² K), h_c (0: vacuum; ~10: still air)")
    contact_conductance: float = Field(20000.0, ge=0, description="W/(m² K), g_c through the contact strip")
    contact_width: float = Field(0.01, gt=0, description="m, w_c: the contact strip's width along the screw")
    load_exponent: float = Field(0.0, ge=0, description="n_F: G ∝ (F_n/F_ref)^n_F, close-contact melting (0: off)")
    reference_load: float = Field(80.0, gt=0, description="N, F_ref of the load exponent")
    contact_force: float = Field(1.0, ge=0, description="N, a screw is in contact above this normal force")
    ice_density: float = Field(RHO_ICE, gt=0, description="kg/m³, ρ_i")
    latent_heat: float = Field(LATENT_FUSION, gt=0, description="J/kg, L_f")
    ice_specific_heat: float = Field(C_ICE, gt=0, description="J/(kg K), c_i")
    thread_depth: float = Field(0.0175, gt=0, description="m, h_t (EELS 1.5: 0.07 m × (1 − core 0.75))")
    engagement_gain: float = Field(2.0, ge=0, description="k_e: ‖e_v‖ × (1 + k_e min(δ/h_t, 1))")
    groove_length: float = Field(0.05, gt=0, description="m, ℓ_g: the groove relaxes as exp(−distance/ℓ_g) "
                                 "(0.05: the half-width sqrt(2 r h_t) of a groove as deep as the thread, r = 7 cm)")
    still_speed: float = Field(2e-3, gt=0, description="m/s: slower than this a screw is still: an embedded frozen "
                               "screw bonds, and its groove does not relax (a tremble is not a departure)")
    break_speed: float = Field(5e-3, gt=0, description="m/s: faster than this, the bond breaks")
    bond_stress_1s: float = Field(1e3, ge=0, description="Pa, σ_1: the bond's strength after 1 s (assumed)")
    bond_exponent: float = Field(0.5, ge=0, description="n: σ_b = σ_1 (t_b/1 s)^n (assumed)")
    mu_reference: float = Field(1.0, gt=0, description="μ of the contact's material, μ_ref of the bond's μ scale")
    max_penetration: float | None = Field(None, gt=0, description="m, the run stops past it (None: the radius)")
    screws: int = Field(1, ge=1, description="number of screws without a robot")
    radius: float = Field(0.07, gt=0, description="m, screw radius without a robot")
    length: float = Field(0.115, gt=0, description="m, screw length without a robot")


def _per_screw(c):
    return (c.ns,)


def _names(c):
    return c.screw_names


class ScrewHeat(Component[ScrewHeatParams]):
    type_name = "screw_heat"
    robot = Uses(RobotModel, required=False)

    heater_power = Input(shape=_per_screw, unit="W", default=0.0)
    slip_power = Input(shape=_per_screw, unit="W", default=0.0)
    normal_force = Input(shape=_per_screw, unit="N", default=0.0)
    slip_speed = Input(shape=_per_screw, unit="m/s", default=0.0)
    travel_speed = Input(shape=_per_screw, unit="m/s", default=0.0)
    mu_base = Input(shape=_per_screw, unit="1", default=1.0)
    temperature = Output(shape=_per_screw, unit="K", feedthrough=(), names=_names)
    penetration = Output(shape=_per_screw, unit="m", feedthrough=(), names=_names)
    ev_scale = Output(shape=_per_screw, unit="1", feedthrough=(), names=_names)
    mu_scale = Output(shape=_per_screw, unit="1", feedthrough=(), names=_names)
    bond_time = Output(shape=_per_screw, unit="s", feedthrough=(), names=_names)
    ledger = Output(shape=(len(LEDGER),), unit="J", feedthrough=(), names=LEDGER)

    def setup(self):
        p = self.p
        if self.rate is None:
            raise ValueError(f"{self.name}: screw_heat integrates at a rate: give it `rate: HZ` (e.g. 100)")
        if self.robot is not None:
            from snakesim.components.contact.robot_screws import screw_layout
            lay = self.robot.derived(screw_layout)
            self.ns, self.screw_names = lay.ns, tuple(lay.names)
            radius, length = np.asarray(lay.radius, float), np.asarray(lay.length, float)
        else:
            self.ns, self.screw_names = p.screws, tuple(f"screw_{i}" for i in range(p.screws))
            radius, length = np.full(p.screws, p.radius), np.full(p.screws, p.length)
        if self.ns == 0:
            raise ValueError(f"{self.name}: the robot has no screws to heat")
        self.radius = radius
        self.max_penetration = radius if p.max_penetration is None else np.full(self.ns, p.max_penetration)
        area = length * p.contact_width
        self.contact_area = area
        stefan = stefan_energy_density(p.ice_temperature, p.ice_density, p.latent_heat, p.ice_specific_heat,
                                       p.melting_point)
        self.k = constants(c=p.mass * p.specific_heat, eps=p.emissivity, hc=p.convection, tice=p.ice_temperature,
                           tenv=p.environment_temperature, tmelt=p.melting_point, stefan=stefan, rho=p.ice_density,
                           latent=p.latent_heat, groove=p.groove_length, still=p.still_speed, break_=p.break_speed,
                           fcontact=p.contact_force, loadexp=p.load_exponent, fref=p.reference_load)
        self._area_s = np.ascontiguousarray(2.0 * np.pi * radius * length)
        self._area_c = np.ascontiguousarray(area)
        self._g0 = np.ascontiguousarray(p.contact_conductance * area)
        n = self.ns
        self.T, self.D, self.B, self.M = slice(0, n), slice(n, 2 * n), slice(2 * n, 3 * n), slice(3 * n, 4 * n)
        self.L = slice(4 * n, 4 * n + len(LEDGER))

    def discrete_state(self):
        x = np.zeros(4 * self.ns + len(LEDGER))
        x[self.T] = self.p.initial_temperature
        x[self.M] = 1.0                        # mu_base as sampled (1 until the first sample)
        return x

    def output(self, t, x, u, y):
        c = u.cache
        c.x[:] = x
        c.outputs()                            # heat_kernels.heat_outputs: the module docstring's outputs

    def update(self, t, xd, u):
        c = u.cache
        c.xd = xd
        c.x[:] = xd
        code = c.step()                        # heat_kernels.heat_update: heat_step.thermal_step on a copy
        if code < 0:
            s = -1 - code
            heat = float(u.heater_power[s])
            raise ValueError(f"{self.name}: heater_power[{self.screw_names[s]}] = {heat!r} W at t = {t:g} s; valid: "
                             f"a finite power >= 0 (a heater does not cool)")
        xd[:] = c.x
        if code < self.ns:
            self.stop(f"{self.screw_names[code]} melted {1e3 * xd[self.D][code]:.1f} mm into the ice, past the "
                      f"{1e3 * self.max_penetration[code]:.1f} mm limit (max_penetration; default the screw radius)")

    def make_cache(self, x, u, y):
        """The bound kernels over this run's buffers (heat_kernels.py); ``xd`` the discrete state, kept by
        update() for the report. mu_base is held from the sample: the outputs declare no feedthrough, so
        reading the input in output() would see whatever its source (ice_friction, evaluated after the
        contact this feeds) last wrote."""
        p = self.p
        f64 = lambda a: np.ascontiguousarray(a, dtype=float)        # noqa: E731 - the constants
        state = np.array(x, dtype=float)       # the kernels' copy of the state (a record's field is opaque)
        args = HeatArgs(x=state, n=self.ns, h=1.0 / self.rate, nl=len(LEDGER),
                        heater=u.heater_power, slip_power=u.slip_power, normal_force=u.normal_force,
                        slip_speed=u.slip_speed, travel=u.travel_speed, mu_base=u.mu_base,
                        temperature=y.temperature, penetration=y.penetration, ev_scale=y.ev_scale,
                        mu_scale=y.mu_scale, bond_time=y.bond_time, ledger=y.ledger,
                        k=self.k, area_s=self._area_s, area_c=self._area_c, g0=self._g0,
                        max_pen=f64(self.max_penetration), slip_pos=np.zeros(self.ns),
                        thread_depth=float(p.thread_depth), gain=float(p.engagement_gain),
                        mu_ref=float(p.mu_reference), stress_1s=float(p.bond_stress_1s),
                        exponent=float(p.bond_exponent))
        return SimpleNamespace(xd=None, args=args, x=state, step=bind(heat_update, args),
                               outputs=bind(heat_outputs, args))

    # -- the run's report (framework/run_reports.py) ---------------------------------------------
    def report(self, cache, summary: dict) -> dict:
        """Each screw's penetration, temperature and bond hold time at the end; the energy ledger."""
        x = cache.xd if cache is not None and cache.xd is not None else self.discrete_state()
        screws = {name: {"penetration_mm": 1e3 * float(x[self.D][i]), "temperature_C": float(x[self.T][i]) - 273.15,
                         "bond_time_s": float(x[self.B][i])} for i, name in enumerate(self.screw_names)}
        return {"screws": screws, "energy_J": {k: float(v) for k, v in zip(LEDGER, x[self.L])},
                "max_penetration_mm": 1e3 * float(x[self.D].max()), "thread_depth_mm": 1e3 * self.p.thread_depth}

    @staticmethod
    def format_report(r: dict) -> list[str]:
        """Lines for the terminal."""
        per = ", ".join(f"{n} {s['penetration_mm']:.1f} mm at {s['temperature_C']:.1f} °C"
                        for n, s in r["screws"].items())
        e = r["energy_J"]
        return [f"screws in the ice: {per} (thread depth {r['thread_depth_mm']:.1f} mm)",
                f"energy: heater {e['heater_in']:.4g} J, friction {e['friction_in']:.4g} J, "
                f"stored {e['stored']:.4g} J, "
                f"melting {e['to_ice_melting']:.4g} J (latent {e['latent']:.4g}), cold ice {e['to_cold_ice']:.4g} J, "
                f"radiated {e['radiated']:.4g} J, convected {e['convected']:.4g} J, residual {e['residual']:.2g} J"]


__all__ = ["ScrewHeat", "ScrewHeatParams"]
