"""Quasi-static resistive-force reference for planar shape gaits with anisotropic Coulomb friction.

An independent model of a serpenoid gait's locomotion (the validation reference of the
shape-gait scenes; Hirose's serpenoid kinematics, resistive-force/Coulomb friction as in
Hu, Nirody, Scott & Shelley, PNAS 106:10081, 2009), sharing with the simulator only the
gait and the friction law, nothing of its dynamics:

* the shape is *prescribed*: a planar chain of straight links (lengths ``links``) whose
  joint angles follow θ_i(t) = A sin(2π f t − 2π i / λ) exactly (no controller, no lag);
* each link carries its weight m_l g spread evenly over ``per_link`` points on its axis
  (no contact springs, no load transfer);
* inertia is neglected (quasi-static): at every instant the body's planar rigid motion
  (ẋ, ẏ, φ̇) is the one that makes the friction forces balance, Σ f = 0, Σ r × f = 0;
* friction at a point of link l moving at v: f = −w μ (κ (ŝ·t̂) t̂ + (ŝ − (ŝ·t̂) t̂)) · across,
  ŝ = v / sqrt(|v|² + v_ε²), t̂ the link axis, κ = along / across: body_contact's law.

The snake's average velocity follows by integrating the rigid motion. What the two models
do not share bounds their agreement: inertia (lateral accelerations ~ a ω² against the
friction deceleration μ_across g), the PID's tracking lag, and the weight distribution.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import fsolve


def _chain(links, angles):
    """Joint positions (n+1, 2) and link headings (n,) of a planar chain, tail at the origin along +x."""
    heading = np.concatenate([[0.0], np.cumsum(angles)])
    steps = np.column_stack([np.cos(heading), np.sin(heading)]) * np.asarray(links)[:, None]
    return np.vstack([[0.0, 0.0], np.cumsum(steps, axis=0)]), heading


def serpenoid_speed(links, masses, wave_joints, *, amplitude, frequency, wavelength, mu, along, across,
                    periods=4.0, dt=2e-3, per_link=5, v_eps=1e-3, g=9.81) -> dict:
    """Average planar velocity of a chain of ``links`` (m, tail first) of ``masses`` (kg) whose joints
    (between consecutive links) ``wave_joints`` (indices, tail first) carry the serpenoid wave; the other
    joints stay straight. Returns {"velocity": mean COM velocity over the last ``periods`` − 1 periods
    (world, m/s, the tail starting along +x), "heading_rate": mean φ̇, "com": COM path}."""
    links, masses = np.asarray(links, float), np.asarray(masses, float)
    n = links.size
    s = (np.arange(per_link) + 0.5) / per_link                       # points along each link
    w = np.repeat(masses * g / per_link, per_link)                   # their weights
    owner = np.repeat(np.arange(n), per_link)
    kappa = along / across
    wave = np.asarray(wave_joints)
    k = -2.0 * math.pi * np.arange(wave.size) / wavelength
    om = 2.0 * math.pi * frequency

    def shape(t):
        q = np.zeros(n - 1)
        q[wave] = amplitude * np.sin(om * t + k)
        joints, heading = _chain(links, q)
        pts = joints[owner] + s[np.arange(owner.size) % per_link, None] * (joints[owner + 1] - joints[owner])
        return pts, heading[:n][owner]

    def forces(twist, R, pts, pts_dot, th):
        vx, vy, wz = twist
        pw = pts @ R.T
        vel = np.column_stack([vx - wz * pw[:, 1], vy + wz * pw[:, 0]]) + pts_dot @ R.T
        tw = np.column_stack([np.cos(th), np.sin(th)]) @ R.T
        sh = vel / np.sqrt((vel ** 2).sum(axis=1) + v_eps ** 2)[:, None]
        st = (sh * tw).sum(axis=1)
        f = -(w * mu * across)[:, None] * (kappa * st[:, None] * tw + (sh - st[:, None] * tw))
        return np.array([f[:, 0].sum(), f[:, 1].sum(), (pw[:, 0] * f[:, 1] - pw[:, 1] * f[:, 0]).sum()]), pw

    X, phi, twist = np.zeros(2), 0.0, np.zeros(3)
    steps = int(round(periods / frequency / dt))
    com = np.empty((steps + 1, 2))
    t_out = np.arange(steps + 1) * dt
    mass_w = np.repeat(masses / per_link, per_link)
    for i in range(steps + 1):
        t = i * dt
        pts, th = shape(t)
        p2, _ = shape(t + 1e-6)
        pts_dot = (p2 - pts) / 1e-6
        c, sn = math.cos(phi), math.sin(phi)
        R = np.array([[c, -sn], [sn, c]])
        twist = fsolve(lambda q: forces(q, R, pts, pts_dot, th)[0], twist, xtol=1e-12)
        pw = pts @ R.T
        com[i] = X + (mass_w @ pw) / mass_w.sum()
        # the body frame's origin moves with ẋ, ẏ; it turns at φ̇ (explicit Euler on the rigid motion)
        X = X + dt * twist[:2]
        phi += dt * twist[2]
    late = t_out >= 1.0 / frequency
    vel = np.array([np.polyfit(t_out[late], com[late, j], 1)[0] for j in range(2)])
    return {"velocity": vel, "heading": phi, "com": com, "t": t_out}
