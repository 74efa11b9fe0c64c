#!/usr/bin/env python3
"""The default sweep study in vectorised NumPy, to time beside the Rust tool.

The same study as `tricept-calib sweep --no-trials` with the built-in paper
config: Table 1 geometry, the 51 default poses, 15 errors uniform in ±0.5 mm
per machine, the paper's sensors (mean of 3 samples, grade = σ) at encoder
grades 0.5–8″ and a 0.5 µm scale, OLS on the nominal design matrix, μ per
calibration. Readings come from exact forward kinematics (Newton on the three
closure equations, converged to 1e-11 mm), vectorised over trials × poses.
By default it uses the tool's own algorithm, written in NumPy: Newton from
the first-order prediction with the first Jacobian reused, one noise draw per
reading shared by every grade and the estimate split by noise source;
`--plain` is the straightforward kernel (Newton from the nominal joints with
a fresh Jacobian per step, independent noise per grade). Random streams
differ from the Rust tool's, so the means agree statistically, not byte for
byte.

    python3 -m venv /tmp/np && /tmp/np/bin/pip install numpy
    /tmp/np/bin/python benches/numpy_study.py --trials 200000

prints one throughput line like the tool's and the mean μ per grade.
"""
import argparse
import time

import numpy as np

A, B = 100.0, 288.7
ANG = np.radians([-60.0, 60.0, 180.0])
GRADES = [0.5, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0]
SCALE_UM, SAMPLES, BOUND = 0.5, 3, 0.5
ARCSEC = np.pi / 180 / 3600


def poses():
    out = []
    for z in (650.0, 750.0, 850.0):
        out.append((0.0, 0.0, z))
        for f in (0.5, 1.0):
            for p in range(8):
                t = np.radians(45.0 * p)
                out.append((f * 400 * np.cos(t), f * 400 * np.sin(t), z))
    return np.array(out)


def rot(psi, th):
    sp, cp, st, ct = np.sin(psi), np.cos(psi), np.sin(th), np.cos(th)
    z, o = np.zeros_like(psi), np.ones_like(psi)
    return np.stack([np.stack([ct, z, st], -1),
                     np.stack([sp * st, cp, -sp * ct], -1),
                     np.stack([-cp * st, sp, cp * ct], -1)], -2)


def legs(j, b, a):
    """Leg lengths |q4·w4 + R·a_i − b_i| for joints j (..., 3); b, a (..., 3, 3)."""
    r = rot(j[..., 0], j[..., 1])
    w4 = r[..., :, 2]
    p = j[..., 2:3, None] * w4[..., None, :] + np.einsum("...kl,...il->...ik", r, a) - b
    return np.linalg.norm(p, axis=-1)


def legs_and_jacobian(j, b, a):
    """Leg lengths and the analytic closure Jacobian d(legs)/d(psi, theta, q4):
    rows [ex·(P×u), e'·(P×u), u·w4] with P = q4·w4 + R·a_i, u the unit leg
    vector and e' = (0, cos psi, sin psi) (as the tool's Machine::closure)."""
    r = rot(j[..., 0], j[..., 1])
    w4 = r[..., :, 2]
    big_p = j[..., 2:3, None] * w4[..., None, :] + np.einsum("...kl,...il->...ik", r, a)
    v = big_p - b
    length = np.linalg.norm(v, axis=-1)
    u = v / length[..., None]
    pxu = np.cross(big_p, u)
    psi = j[..., 0:1]
    jac = np.stack([pxu[..., 0],
                    np.cos(psi) * pxu[..., 1] + np.sin(psi) * pxu[..., 2],
                    np.einsum("...il,...l->...i", u, w4)], -1)
    return length, jac


def machine(e):
    """Joint centres of machines with errors e (n, 15), docs/method.md §3 gauge."""
    n = e.shape[0]
    b = np.broadcast_to(B * np.stack([np.cos(ANG), np.sin(ANG), 0 * ANG], -1), (n, 3, 3)).copy()
    a = np.broadcast_to(A * np.stack([np.cos(ANG), np.sin(ANG), 0 * ANG], -1), (n, 3, 3)).copy()
    b[:, 0, :2] += e[:, [0, 1]]
    b[:, 1, :2] += e[:, [0, 2]]
    b[:, 2, :] += e[:, 3:6]
    a[:, :, :2] += e[:, 6:12].reshape(n, 3, 2)
    return b, a, e[:, 12:15]


def forward(q, b, a, dq, guess):
    """Joints of machines (b, a, dq) at commands q, Newton from guess."""
    j = guess.copy()
    target = q + dq
    h = 1e-7
    for _ in range(40):
        f = legs(j, b, a) - target
        if np.abs(f).max() < 1e-11:
            break
        jac = np.empty(f.shape + (3,))
        for k in range(3):
            d = np.zeros(3)
            d[k] = h
            jac[..., k] = (legs(j + d, b, a) - legs(j - d, b, a)) / (2 * h)
        j = j - np.linalg.solve(jac, f[..., None])[..., 0]
    return j


def forward_near(q, b, a, dq, guess):
    """The tool's kernel: Newton from `guess` (the first-order prediction)
    with the Jacobian of the first iterate reused (chord), same tolerance."""
    j = guess.copy()
    target = q + dq
    length, jac = legs_and_jacobian(j, b, a)
    f = length - target
    inv = np.linalg.inv(jac)
    for _ in range(40):
        if np.abs(f).max() < 1e-11:
            break
        j = j - np.einsum("...kl,...l->...k", inv, f)
        f = legs(j, b, a) - target
    return j


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--trials", type=int, default=200000)
    ap.add_argument("--chunk", type=int, default=4000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--plain", action="store_true",
                    help="Newton from the nominal joints with a fresh Jacobian each step and "
                         "independent noise per grade (the kernel before the tool's own tricks)")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    r = poses()
    q4 = np.linalg.norm(r, axis=1)
    nom = np.stack([np.arctan2(-r[:, 1], r[:, 2]), np.arcsin(r[:, 0] / q4), q4], -1)
    b0, a0, _ = machine(np.zeros((1, 15)))
    q_cmd = legs(nom, b0[0], a0[0])
    # Design matrix by central differences of exact FK, OLS operator on the
    # identifiable columns (dyA3's column is zero in this layout).
    h = 1e-5
    cols = []
    per_pose = []  # J_k: d(joints at pose k)/d(error), for the first-order start
    for k in range(15):
        e = np.zeros((2, 15))
        e[0, k], e[1, k] = h, -h
        bb, aa, dd = machine(e)
        x = forward(q_cmd[None], bb[:, None], aa[:, None], dd[:, None], np.broadcast_to(nom, (2,) + nom.shape))
        d = (x[0] - x[1]) / (2 * h)
        per_pose.append(d)
        cols.append(((d[1:] - d[0]) ).reshape(-1))
    H = np.stack(cols, -1)
    keep = np.linalg.norm(H, axis=0) > 1e-9 * np.linalg.norm(H, axis=0).max()
    op = np.zeros((15, H.shape[0]))
    op[keep] = np.linalg.pinv(H[:, keep])
    jk = np.stack(per_pose, -1)  # (poses, 3, 15)
    # The split operator (the tool's LinearSolver::apply_split): op applied
    # to each sensor's rows alone.
    op_sensor = [op * (np.arange(H.shape[0]) % 3 == c) for c in range(3)]
    sig = np.array([[g * ARCSEC, g * ARCSEC, SCALE_UM * 1e-3] for g in GRADES]) / np.sqrt(SAMPLES)
    mu_sum = np.zeros(len(GRADES))
    started = time.perf_counter()
    done = 0
    while done < args.trials:
        n = min(args.chunk, args.trials - done)
        e = rng.uniform(-BOUND, BOUND, (n, 15))
        b, a, dq = machine(e)
        if args.plain:
            x = forward(q_cmd[None], b[:, None], a[:, None], dq[:, None],
                        np.broadcast_to(nom, (n,) + nom.shape))
        else:
            guess = nom + np.einsum("pcs,ns->npc", jk, e)
            x = forward_near(q_cmd[None], b[:, None], a[:, None], dq[:, None], guess)
        l0 = ((x[:, 1:] - x[:, :1]) - (nom[1:] - nom[:1])).reshape(n, -1)
        if args.plain:
            for g in range(len(GRADES)):
                noise = rng.standard_normal((n, nom.shape[0], 3)) * sig[g]
                l = l0 + (noise[:, 1:] - noise[:, :1]).reshape(n, -1)
                est = l @ op.T
                mu_sum[g] += np.abs(e - est).mean(axis=1).sum()
        else:
            # Common random numbers: one unit draw per reading for every
            # grade; the estimate is linear in it.
            z = rng.standard_normal((n, nom.shape[0], 3))
            dz = (z[:, 1:] - z[:, :1]).reshape(n, -1)
            base = l0 @ op.T
            parts = [dz @ o.T for o in op_sensor]
            for g in range(len(GRADES)):
                est = base + sum(sig[g][c] * parts[c] for c in range(3))
                mu_sum[g] += np.abs(e - est).mean(axis=1).sum()
        done += n
    wall = time.perf_counter() - started
    calib = args.trials * len(GRADES)
    print(f"throughput: {calib} calibrations in {wall:.3f} s = {calib / wall:.0f} calibrations/s (NumPy {np.__version__})")
    for g, m in zip(GRADES, mu_sum / args.trials):
        print(f"  encoder {g}\" / scale {SCALE_UM} um: mean mu {m:.5f} mm")


if __name__ == "__main__":
    main()
