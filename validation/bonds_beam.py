"""A bonded slab floating on the sea (effect ``bonds``) against beam theory: a beam on an
elastic foundation (buoyancy, k = rho_w g = 1), the three checks of issue #31.

    python validation/bonds_beam.py hetenyi    # settled deflection under a point load
    python validation/bonds_beam.py modes      # flexural-gravity standing modes
    python validation/bonds_beam.py breaking   # the load that breaks the first bond
    python validation/bonds_beam.py all        # the three (~1.5 min on one core)

The slab: ``n`` upright blocks of width ``b`` and thickness ``t`` (``[[iceberg]]`` tables,
faces touching, each neighbour pair a ``[[bond]]``), floating at rest (draft ``r t``). Its
bonds make a beam (a plate in plane strain) of ``D = E' I``, ``E' = E / (1 - nu^2)``,
``I = t^3 / 12``; buoyancy is the Winkler foundation, so ``beta = (k / 4 D)^(1/4)``, and
``1 / beta`` is sqrt(2) times the flexural length ``(D / k)^(1/4)``. The point load: the middle block is taller upward by
``delta`` (its bottom at its neighbours' depth, so the bonded faces are the same), which
adds the weight ``P = r delta b`` and no buoyancy.

Beside each formula, :func:`discrete` solves the same slab as the model's linear algebra
(numpy, no Taichi): each block's three degrees of freedom, the bonds' springs on the
relative motion of their two points, each block's hydrostatic heave ``b`` and tilt
stiffness ``b^3/12 - V (z_G - z_B)`` (its centre of mass above its centre of buoyancy). It
is what a chain of rigid blocks must do; the model should match it closely, and its gap
to the formula is the block size's (shear of the bonds, ``G t / L``, is a Timoshenko beam's).
Writes ``validation/results/bonds/*.csv`` and ``*.png``.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

R = 0.8946  # density ratio (the default)
E0 = 1420.7219  # the default bond_modulus (1 GPa at w = 70 m)
SIGMA_T = 0.3552  # the default tensile_strength
NU = 0.3  # the default poisson_ratio


def plane_strain(E: float) -> float:
    """``E' = E / (1 - nu^2)``: the modulus of the bonds' normal and bending stiffness."""
    return E / (1.0 - NU * NU)


UNBREAKABLE = 1e9


# ------------------------------------------------------------------ scenes


def slab_text(
    n: int,
    b: float,
    t: float = 1.0,
    delta: float = 0.0,
    *,
    E: float = E0,
    dt: float,
    duration: float,
    drag: float = 0.0,
    zeta: float = 0.0,
    strength: float = UNBREAKABLE,
    snapshot: float | None = None,
    vz=None,
    omega=None,
    layers: int = 1,
    loaded: int | None = None,
) -> str:
    """The scene text of a bonded slab of ``n`` blocks centred on x = 0 (the middle block,
    ``n // 2``, taller upward by ``delta``); ``vz``, ``omega``: initial velocities per block;
    ``layers``: each block as that many cells through its thickness (``cells = [1, layers]``,
    bonded to each other and, across each joint, layer to layer); ``loaded``: the taller block
    instead of the middle one (0: the free end), at x = 0."""
    mid = n // 2 if loaded is None else loaded
    effects = '"gravity", "buoyancy", "bonds"' + (', "drag"' if drag > 0 else "")
    out = [
        f'[scene]\nname = "bonds_beam"\neffects = [{effects}]\n',
        f"[physics]\ndensity_ratio = {R}\ndrag = {drag}\nangular_drag = {drag}\nbond_modulus = {E!r}\n"
        f"bond_damping = {zeta}\ntensile_strength = {strength!r}\nshear_strength = {UNBREAKABLE!r}\n",
        f"[time]\ndt = {dt!r}\nduration = {duration!r}\n",
        f"[output]\nsnapshot_interval = {snapshot or duration / 4!r}\ndiagnostic_interval = {min(1.0, duration)!r}\n"
        f"checkpoint_interval = 1e6\n",
    ]
    for i in range(n):
        th = t + (delta if i == mid else 0.0)
        extra = ""
        if vz is not None:
            extra = f"vz = {float(vz[i])!r}\nomega = {float(omega[i])!r}\n"
        if layers > 1:
            extra += f"cells = [1, {layers}]\n"
        out.append(f"[[iceberg]]\nx = {(i - mid) * b!r}\nz = {-R * t + th / 2!r}\nwidth = {b!r}\nthickness = {th!r}\n{extra}")
    out += [f"[[bond]]\na = {i}\nb = {i + 1}\n" for i in range(n - 1)]
    return "\n".join(out)


def stable_dt(text: str, safety: float = 0.8) -> float:
    """A step of 1 / whole, at most ``safety`` times the bonds' largest stable step for the
    scene (the limit the scene's check refuses above: ``bonds.host.dt_limit`` of
    ``omega_max``)."""
    import melange_ti.scene
    from melange_ti.physics.effects.bonds import host

    sc = melange_ti.scene.loads(text.replace("dt = ", "dt = 1e-6 #", 1))
    bergs = sc.icebergs()
    pairs, _ = host.pairs(sc, bergs)
    om = host.omega_max(host.build(sc, bergs, pairs), bergs, sc.physics.density_ratio)
    return 1.0 / math.ceil(1.0 / (safety * host.dt_limit(om, sc.physics.bond_damping)))


def run_text(text: str, path: str | Path) -> dict:
    import melange_ti
    import melange_ti.scene
    from melange_ti.io.hdf5 import read_run

    melange_ti.run(melange_ti.scene.loads(text), out=str(path), overwrite=True)
    return read_run(str(path))


def slab(n, b, t=1.0, delta=0.0, **kw) -> str:
    """:func:`slab_text` at 0.8 of the bonds' stable step (unless ``dt`` is given)."""
    if "dt" not in kw:
        probe = slab_text(n, b, t, delta, dt=1.0, duration=1.0, **{k: v for k, v in kw.items() if k != "duration"})
        kw["dt"] = stable_dt(probe)
    return slab_text(n, b, t, delta, **kw)


# ------------------------------------------------------------------ theory


def beta_of(E: float, t: float, k: float = 1.0) -> float:
    return (k / (4.0 * plane_strain(E) * t**3 / 12.0)) ** 0.25


def hetenyi(x, P: float, beta: float, k: float = 1.0):
    """Deflection (down +) of an infinite beam on a Winkler foundation under a point load P."""
    u = beta * np.abs(x)
    return P * beta / (2 * k) * np.exp(-u) * (np.cos(u) + np.sin(u))


def timoshenko_w0(P: float, E: float, t: float, k: float = 1.0) -> float:
    """Deflection under the load of a Timoshenko beam (shear stiffness G t, the bonds') on
    the same foundation: (1/pi) int_0^inf P dxi / (k + EI xi^4 / (1 + EI xi^2 / G t))."""
    from scipy.integrate import quad

    ei, gt = plane_strain(E) * t**3 / 12.0, E / (2 * (1 + NU)) * t
    f = lambda xi: 1.0 / (k + ei * xi**4 / (1.0 + ei * xi**2 / gt))  # noqa: E731
    return P / math.pi * quad(f, 0, np.inf, limit=400)[0]


def p_crit(E: float, t: float, sigma_t: float) -> float:
    """The load whose peak moment P / (4 beta) makes the bond's tensile stress 6 M / t^2
    reach sigma_t: P = 4 beta sigma_t t^2 / 6 = (2/3) beta sigma_t t^2."""
    return 4.0 * beta_of(E, t) * sigma_t * t**2 / 6.0


FREE_FREE = (4.730040745, 7.853204624, 10.99560784, 14.13716549, 17.27875966)


def free_free(x, L: float, kl: float):
    """The free-free beam's mode of ``k L = kl`` at x in [0, L] and its slope, scaled to
    max |phi| = 1 (the same shapes on a uniform foundation)."""
    k = kl / L
    sig = (math.cosh(kl) - math.cos(kl)) / (math.sinh(kl) - math.sin(kl))
    kx = k * np.asarray(x)
    phi = np.cosh(kx) + np.cos(kx) - sig * (np.sinh(kx) + np.sin(kx))
    dphi = k * (np.sinh(kx) - np.sin(kx) - sig * (np.cosh(kx) + np.cos(kx)))
    s = np.abs(phi).max()
    return phi / s, dphi / s


def omega_fg(E: float, t: float, k_wave: float) -> float:
    """Flexural-gravity frequency: omega^2 = (E' I k^4 + rho_w g) / (rho_i t)."""
    return math.sqrt((plane_strain(E) * t**3 / 12.0 * k_wave**4 + 1.0) / (R * t))


def omega_timoshenko(E: float, t: float, k_wave: float) -> float:
    """The same wave on a Timoshenko beam (shear stiffness G t, the bonds'; rotary inertia
    rho_i t^3 / 12): the lower root of (a - rho_i t w^2)(d - rho_i I w^2) = (G t k)^2,
    a = G t k^2 + rho_w g, d = E I k^2 + G t."""
    gt, ei = E / (2 * (1 + NU)) * t, plane_strain(E) * t**3 / 12
    ra, ri = R * t, R * t**3 / 12
    a, d = gt * k_wave**2 + 1.0, ei * k_wave**2 + gt
    qa, qb, qc = ra * ri, -(a * ri + d * ra), a * d - (gt * k_wave) ** 2
    return math.sqrt((-qb - math.sqrt(qb * qb - 4 * qa * qc)) / (2 * qa))


# ------------------------------------------------------------------ the discrete slab


def discrete(n: int, b: float, t: float = 1.0, delta: float = 0.0, E: float = E0, loaded: int | None = None):
    """The slab's linear algebra: ``(K, M, f, bonds)`` over the blocks' ``(x, z, theta)``,
    ``f`` the load (the middle block's extra weight), ``bonds`` each bond's ``(x, kn, kb,
    J)`` (J: the rows of d_n, d_s, dth)."""
    mid = n // 2 if loaded is None else loaded
    th = np.full(n, t)
    th[mid] += delta
    xc = (np.arange(n) - mid) * b
    zc = -R * t + th / 2
    mass = R * b * th
    inertia = mass * (b**2 + th**2) / 12
    K = np.zeros((3 * n, 3 * n))
    G = E / (2 * (1 + NU))
    kn, ks, kb = plane_strain(E) * t / b, G * t / b, plane_strain(E) * t**3 / (12 * b)
    bonds = []
    zb = -R * t / 2  # the shared faces' middle: the neighbours' centre height
    for i in range(n - 1):
        ra = np.array([b / 2, zb - zc[i]])
        rb = np.array([-b / 2, zb - zc[i + 1]])
        J = np.zeros((3, 3 * n))
        for q, v in enumerate((np.array([1.0, 0.0]), np.array([0.0, 1.0]))):
            J[q, 3 * i : 3 * i + 2] = -v
            J[q, 3 * i + 2] = -(v[1] * ra[0] - v[0] * ra[1])
            J[q, 3 * i + 3 : 3 * i + 5] = v
            J[q, 3 * i + 5] = v[1] * rb[0] - v[0] * rb[1]
        J[2, 3 * i + 2], J[2, 3 * i + 5] = -1.0, 1.0
        K += J.T @ np.diag([kn, ks, kb]) @ J
        bonds.append((xc[i] + b / 2, kn, kb, J))
    # hydrostatics: heave b (k = 1 per unit length), tilt b^3/12 + V (z_B - z_G)
    vol = R * t * b
    K[1::3, 1::3] += np.eye(n) * b
    K[2::3, 2::3] += np.diag(b**3 / 12 + vol * (-R * t / 2 - zc))
    K[0::3, 0::3] += np.eye(n) * 1e-9 * b  # x is free: pin the mean
    f = np.zeros(3 * n)
    f[3 * mid + 1] = -R * delta * b
    M = np.diag(np.stack([mass, mass, inertia], 1).reshape(-1))
    return K, M, f, bonds


def discrete_static(n, b, t=1.0, delta=0.0, E=E0, loaded=None):
    """Settled deflection (down +) at the blocks' centres and each bond's tensile stress
    F_n / t + 6 |M| / t^2 (and the bonds' x)."""
    K, _, f, bonds = discrete(n, b, t, delta, E, loaded)
    u = np.linalg.solve(K, f)
    sig = np.array([(kn * (J[0] @ u)) / t + 6 * abs(kb * (J[2] @ u)) / t**2 for _, kn, kb, J in bonds])
    return -u[1::3], sig, np.array([x for x, *_ in bonds])


def discrete_omega(n, b, t, kl, E=E0):
    """The discrete slab's angular frequency of the mode closest to the free-free shape
    ``kl`` (generalised eigenproblem K phi = omega^2 M phi)."""
    from scipy.linalg import eigh

    K, M, _, _ = discrete(n, b, t, 0.0, E)
    w2, vec = eigh(K, M)
    x = (np.arange(n) + 0.5) * b
    phi, _ = free_free(x, n * b, kl)
    zs = vec[1::3]
    mz = M[1::3, 1::3] @ zs
    match = np.abs(phi @ mz) / np.sqrt((zs * mz).sum(0).clip(1e-300))
    return math.sqrt(w2[int(np.argmax(match))])


# ------------------------------------------------------------------ 1. Hetenyi


def settle(n, b, t, P, E=E0, duration=30.0, work=None):
    """A slab settled under ``P`` (drag 1, bond_damping 0.05, unbreakable bonds): the
    deflection (down +) at each block centre, the block centres and the last two
    snapshots' largest difference (how settled)."""
    delta = P / (R * b)
    text = slab(n, b, t, delta, E=E, duration=duration, drag=1.0, zeta=0.05)
    out = run_text(text, Path(work or tempfile.mkdtemp()) / f"settle_{n}_{b:g}.h5")
    z = out["snapshots"]["z"]
    th = np.full(n, t)
    th[n // 2] += delta
    z0 = -R * t + th / 2
    w = -(z[-1] - z0)
    return w, (np.arange(n) - n // 2) * b, float(np.abs(z[-1] - z[-2]).max()), out


def hetenyi_study(
    out_dir: Path, series=((E0, (1.0, 0.5, 0.25, 0.125)), (16 * E0, (1.0, 0.5, 0.25))), t=1.0, P=0.2, half=6.5, work=None
):
    """The settled deflection against Hetenyi's for blocks of each width (the slab's half
    length ``half / beta``), at the default modulus and at 16 times it (a flexural length
    twice as long in w: the bonds' shear, a Timoshenko beam's, a quarter as large)."""
    rows, profiles = [], {}
    for E, widths in series:
        beta = beta_of(E, t)
        for b in widths:
            n = 2 * int(math.ceil(half / beta / b)) + 1
            w, x, moving, _ = settle(n, b, t, P, E=E, work=work)
            wd, _, _ = discrete_static(n, b, t, P / (R * b), E=E)
            wh = hetenyi(x, P, beta)
            w0h, w0, w0t = float(wh[n // 2]), float(w[n // 2]), timoshenko_w0(P, E, t)
            near = np.abs(x) <= 3 / beta
            rows.append(
                dict(
                    bond_modulus=E,
                    width=b,
                    blocks=n,
                    blocks_per_flexural_length=1 / (beta * b),
                    w0_model=w0,
                    w0_hetenyi=w0h,
                    error=w0 / w0h - 1,
                    profile_error=float(np.abs(w - wh)[near].max() / w0h),
                    w0_timoshenko=w0t,
                    error_vs_timoshenko=w0 / w0t - 1,
                    w0_discrete=float(wd[n // 2]),
                    model_vs_discrete=w0 / float(wd[n // 2]) - 1,
                    still_moving=moving,
                )
            )
            if E == E0:
                profiles[b] = (x, w)
            r = rows[-1]
            print(
                f"hetenyi E={E:g} b={b:g} n={n}: w0 {w0:.6f} vs {w0h:.6f} ({r['error']:+.2%}), "
                f"profile {r['profile_error']:.2%}, timoshenko {w0t:.6f} ({r['error_vs_timoshenko']:+.2%}), "
                f"discrete {r['w0_discrete']:.6f} ({r['model_vs_discrete']:+.3%})",
                flush=True,
            )
    write_csv(out_dir / "hetenyi.csv", rows)
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4))
    beta = beta_of(E0, t)
    xs = np.linspace(-4 / beta, 4 / beta, 801)
    a1.plot(xs, -hetenyi(xs, P, beta), "k-", lw=1, label="Hetényi (1946)")
    for b, (x, w) in profiles.items():
        a1.plot(x, -w, ".", ms=3, label=f"model, b = {b:g}")
    a1.set(
        xlabel="x (w)", ylabel="deflection (w)", xlim=(-4 / beta, 4 / beta), title=f"point load P = {P:g}, t = {t:g}, E = {E0:g}"
    )
    a1.legend(fontsize=8)
    for E, mk in zip(sorted({r["bond_modulus"] for r in rows}), ("o", "s"), strict=True):
        rs = [r for r in rows if r["bond_modulus"] == E]
        bpf = [r["blocks_per_flexural_length"] for r in rs]
        lab = f"E = {E / E0:g} x default"
        a2.plot(bpf, [100 * r["error"] for r in rs], mk + "-", label=f"model vs Hetényi, {lab}")
        a2.plot(bpf, [100 * (r["w0_discrete"] / r["w0_hetenyi"] - 1) for r in rs], "k" + "x", ms=8)
        a2.axhline(
            100 * (rs[0]["w0_timoshenko"] / rs[0]["w0_hetenyi"] - 1),
            color=a2.lines[-2].get_color(),
            ls="-.",
            lw=0.8,
            label=f"Timoshenko beam (shear G t) vs Hetényi, {lab}",
        )
    a2.plot([], [], "kx", label="rigid-block chain (numpy)")
    a2.axhspan(-2, 2, color="g", alpha=0.1)
    a2.set(
        xscale="log",
        xlabel="blocks per flexural length 1/(beta b)",
        ylabel="error under the load (%)",
        title="convergence with block count",
    )
    a2.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out_dir / "hetenyi.png", dpi=120)
    return rows


# ------------------------------------------------------------------ 2. flexural-gravity modes


def crossings(tt, a):
    """Times of the upward zero crossings of ``a(t)`` (linear interpolation)."""
    i = np.nonzero((a[:-1] < 0) & (a[1:] >= 0))[0]
    return tt[i] - a[i] * (tt[i + 1] - tt[i]) / (a[i + 1] - a[i])


def mode_run(b, t, L, kl, periods=10.0, amplitude=0.01, snapshot=0.05, work=None, layers=1):
    """A free slab of length L (no drag, no dashpot, no added mass) set moving in the
    free-free mode ``kl`` (initial velocity ``amplitude * omega * phi``, rest shape flat,
    so the bonds start at rest); its mode amplitude (the mass-weighted projection of the
    heave on phi) and the frequency from its upward zero crossings in each half of the run.
    ``layers``: each block as that many bonded cells through its thickness (a block's heave:
    the mean of its cells')."""
    n = int(round(L / b))
    x = (np.arange(n) + 0.5) * b
    phi, dphi = free_free(x, n * b, kl)
    om_th = omega_fg(E0, t, kl / (n * b))
    duration = periods * 2 * math.pi / om_th
    text = slab(
        n,
        b,
        t,
        0.0,
        duration=duration,
        snapshot=snapshot,
        vz=amplitude * om_th * phi,
        omega=amplitude * om_th * dphi,
        layers=layers,
    )
    out = run_text(text, Path(work or tempfile.mkdtemp()) / f"mode_{kl:.3f}_{layers}.h5")
    tt = out["snapshots"]["time"]
    z = out["snapshots"]["z"]
    w = z.reshape(z.shape[0], n, layers).mean(-1) - (-R * t + t / 2)
    a = w @ phi / (phi @ phi)
    c = crossings(tt, a)
    half = len(c) // 2
    om = lambda cc: 2 * math.pi * (len(cc) - 1) / (cc[-1] - cc[0])  # noqa: E731
    return dict(
        kL=kl,
        k=kl / (n * b),
        width=b,
        blocks=n,
        blocks_per_wavelength=2 * math.pi / (kl / (n * b)) / b,
        omega_theory=om_th,
        omega_first_half=om(c[: half + 1]),
        omega_second_half=om(c[half:]),
        omega_discrete=discrete_omega(n, b, t, kl),
        bending_share=1 - 1 / (R * t * om_th**2),
        omega_timoshenko=omega_timoshenko(E0, t, kl / (n * b)),
    ), (tt, a)


def modes_study(out_dir: Path, b=0.25, t=1.0, L=40.0, modes=(10.99560784, 17.27875966), work=None):
    """Two symmetric free-free modes of a slab 40 w long (k t = 0.27 and 0.43)."""
    rows, series = [], []
    for kl in modes:
        row, s = mode_run(b, t, L, kl, work=work)
        for h in ("first_half", "second_half"):
            row[f"error_{h}"] = row[f"omega_{h}"] / row["omega_theory"] - 1
        rows.append(row)
        series.append(s)
        print(
            f"mode kL={kl:.3f}: omega {row['omega_first_half']:.5f} / {row['omega_second_half']:.5f} "
            f"vs {row['omega_theory']:.5f} ({row['error_first_half']:+.2%}, {row['error_second_half']:+.2%}); "
            f"discrete {row['omega_discrete']:.5f}",
            flush=True,
        )
    write_csv(out_dir / "modes.csv", rows)
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4))
    for row, (tt, a) in zip(rows, series, strict=True):
        a1.plot(tt, a, lw=0.8, label=f"k L = {row['kL']:.3f}")
    a1.set(xlabel="t (sqrt(w/g))", ylabel="mode amplitude (w)", title=f"free slab, L = {L:g}, b = {b:g}, t = {t:g}")
    a1.legend(fontsize=8)
    ks = np.linspace(0, 1.2 * max(r["k"] for r in rows), 200)
    a2.plot(ks, [omega_fg(E0, t, k) for k in ks], "k-", lw=1, label="omega^2 = (E I k^4 + rho_w g) / (rho_i t)")
    a2.plot(ks, [omega_timoshenko(E0, t, k) for k in ks], "k:", lw=1, label="Timoshenko beam (shear G t, rotary inertia)")
    a2.plot([r["k"] for r in rows], [r["omega_first_half"] for r in rows], "o", mfc="none", label="model, first half")
    a2.plot([r["k"] for r in rows], [r["omega_second_half"] for r in rows], "x", label="model, second half")
    a2.set(xlabel="k (1/w)", ylabel="omega (1/sqrt(w/g))", title="flexural-gravity dispersion")
    a2.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out_dir / "modes.png", dpi=120)
    return rows


# ------------------------------------------------------------------ 3. the breaking load


def breaks(n, b, t, P, sigma_t=SIGMA_T, work=None, settle_time=30.0):
    """Settle the slab under ``P`` with unbreakable bonds, then restart from the settled
    state with the tensile strength ``sigma_t`` (a [start] keeps the bonds' rest geometry):
    ``(broke, the x of the bonds that broke first, ';'-joined, the bonds' break times)``."""
    import melange_ti
    import melange_ti.scene
    from melange_ti.io.hdf5 import read_run

    work = Path(work or tempfile.mkdtemp())
    delta = P / (R * b)
    text = slab(n, b, t, delta, duration=settle_time, drag=1.0, zeta=0.05)
    first = work / f"load_{P:.6f}.h5"
    melange_ti.run(melange_ti.scene.loads(text), out=str(first), overwrite=True)
    restart = text.split("[[iceberg]]")[0].replace(f"tensile_strength = {UNBREAKABLE!r}", f"tensile_strength = {sigma_t!r}")
    restart = restart.replace(f"duration = {settle_time!r}", "duration = 2.0")
    restart += f'\n[start]\nfile = "{first}"\ntime = {settle_time!r}\n'
    second = work / f"break_{P:.6f}.h5"
    melange_ti.run(melange_ti.scene.loads(restart), out=str(second), overwrite=True)
    r = read_run(str(second))
    bt = r["bonds"]["break_time"]
    a = np.asarray(r["bonds"]["a"]).astype(np.int64)
    x0 = read_run(str(first))["snapshots"]["x"][0]
    if np.all(np.isnan(bt)):
        return False, "", bt
    first = np.nonzero(bt == np.nanmin(bt))[0]  # every bond broken at the first break's step
    return True, ";".join(f"{0.5 * (x0[a[k]] + x0[a[k] + 1]):g}" for k in first), bt


def breaking_study(out_dir: Path, b=0.125, t=1.0, half=6.5, sigma_t=SIGMA_T, iterations=6, work=None):
    beta = beta_of(E0, t)
    n = 2 * int(math.ceil(half / beta / b)) + 1
    pc = p_crit(E0, t, sigma_t)
    _, sig, xb = discrete_static(n, b, t, 1.0 / (R * b))
    pc_discrete = sigma_t / sig.max()
    lo, hi = 0.9 * pc, 1.1 * pc
    trials = []
    for P in (lo, hi):
        broke, xbreak, _ = breaks(n, b, t, P, sigma_t, work)
        trials.append((P, broke, xbreak))
        print(f"breaking P={P:.6f}: broke={broke} at x={xbreak}", flush=True)
    if trials[0][1] or not trials[1][1]:
        raise SystemExit(f"bracket [{lo:g}, {hi:g}] does not bracket the first break: {trials}")
    for _ in range(iterations):
        P = 0.5 * (lo + hi)
        broke, xbreak, _ = breaks(n, b, t, P, sigma_t, work)
        trials.append((P, broke, xbreak))
        print(f"breaking P={P:.6f}: broke={broke} at x={xbreak}", flush=True)
        lo, hi = (lo, P) if broke else (P, hi)
    first_x = [float(v) for v in next(x for p, _, x in trials if p == hi).split(";")]
    row = dict(
        width=b,
        blocks=n,
        blocks_per_flexural_length=1 / (beta * b),
        tensile_strength=sigma_t,
        P_crit_formula=pc,
        P_crit_model_low=lo,
        P_crit_model_high=hi,
        P_crit_model=0.5 * (lo + hi),
        error=0.5 * (lo + hi) / pc - 1,
        P_crit_discrete=pc_discrete,
        first_break_x_at_P_high=next(x for p, br, x in trials if p == hi),
        peak_moment_bonds_x=f"{-b / 2:g};{b / 2:g}",
    )
    write_csv(out_dir / "breaking.csv", [row])
    write_csv(out_dir / "breaking_trials.csv", [dict(P=p, broke=int(br), first_break_x=x) for p, br, x in trials])
    print(
        f"breaking: P_crit {row['P_crit_model']:.6f} in [{lo:.6f}, {hi:.6f}] vs {pc:.6f} ({row['error']:+.2%}); "
        f"discrete {pc_discrete:.6f}",
        flush=True,
    )
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4))
    xs = np.linspace(-3 / beta, 3 / beta, 601)
    u = beta * np.abs(xs)
    Pm = row["P_crit_model"]
    a1.plot(
        xs,
        6 * Pm / (4 * beta) * np.exp(-u) * np.abs(np.cos(u) - np.sin(u)) / t**2,
        "k-",
        lw=1,
        label="6 |M| / t^2, Hetényi, P = P_crit (model)",
    )
    a1.plot(xb, sig * Pm, ".", ms=3, label="bond stress, rigid-block chain (numpy)")
    a1.axhline(sigma_t, color="r", ls="--", label="tensile_strength")
    for x in first_x:
        a1.axvline(x, color="b", alpha=0.3)
    a1.set_xlim(-1.5 / beta, 1.5 / beta)
    a1.set(xlabel="x (w)", ylabel="tensile stress (rho_w g w)", title="first broken bond at the lowest breaking P (blue)")
    a1.legend(fontsize=7, loc="center left")
    ps = [p for p, _, _ in trials]
    a2.plot(range(len(ps)), ps, "o-", color="grey")
    for k, (p, br, _) in enumerate(trials):
        a2.plot(k, p, "rs" if br else "go")
    a2.axhline(pc, color="k", label="P_crit = 4 beta sigma_t t^2 / 6")
    a2.axhspan(0.95 * pc, 1.05 * pc, color="k", alpha=0.08, label="± 5%")
    a2.set(xlabel="trial (bisection)", ylabel="P (rho_w g w^2)", title="red: a bond broke; green: none")
    a2.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out_dir / "breaking.png", dpi=120)
    return row


# ------------------------------------------------------------------ helpers


# ------------------------------------------------------------------ 4. a load at the free edge


def edge_peak(E: float, t: float) -> float:
    """Where a semi-infinite floating beam loaded at its free end bends most: its moment
    ``M(x) = -(P / beta) e^(-beta x) sin(beta x)`` peaks at ``x = pi / (4 beta)`` (the
    footloose distance; ``1 / beta`` is sqrt(2) times the flexural length)."""
    return math.pi / (4.0 * beta_of(E, t))


def settled_stresses(path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each bond's tensile stress ``F_n / t + 6 |M| / t^2`` in the last snapshot of a run
    (from its bonds' rest table, docs/bonds.md), its x at t = 0 and whether it joins two
    blocks side by side (its normal along x; not two layers of one block)."""
    from melange_ti.io.hdf5 import read_run
    from melange_ti.physics.effects.bonds import REST

    r = read_run(str(path))
    s, rest = r["snapshots"], np.asarray(r["bonds"]["rest"])
    col = {name: rest[:, k] for k, name in enumerate(REST)}
    a, b = col["A"].astype(np.int64), col["B"].astype(np.int64)
    x, z, th = s["x"][-1], s["z"][-1], s["theta"][-1]

    def at(i, u, v):
        c, sn = np.cos(th[i]), np.sin(th[i])
        return np.stack([x[i] + c * u - sn * v, z[i] + sn * u + c * v], -1)

    d = at(b, col["UB"], col["VB"]) - at(a, col["UA"], col["VA"])
    ca, sa = np.cos(th[a]), np.sin(th[a])
    n = np.stack([ca * col["NU"] - sa * col["NV"], sa * col["NU"] + ca * col["NV"]], -1)
    fn = col["KN"] * np.sum(d * n, -1)
    m = col["KB"] * (th[b] - th[a] - col["DTH"])
    x0 = s["x"][0][a] + np.cos(s["theta"][0][a]) * col["UA"] - np.sin(s["theta"][0][a]) * col["VA"]
    return fn / col["LEN"] + 6 * np.abs(m) / col["LEN"] ** 2, x0, np.abs(col["NU"]) > 0.5


def edge_run(b, t=1.0, E=E0, P=0.05, length=7.0, work=None, settle_time=30.0, layers=1) -> dict:
    """A floating slab ``length / beta`` long, its end block (at x = 0, its free face at
    ``-b/2``) taller by ``delta``: a point load ``P`` at the free edge. Settled with unbreakable
    bonds; the bonds' stresses read from the settled state; restarted with the tensile
    strength 0.9995 of the largest: the bonds that break first (the peak is flat: two
    neighbours may both be within 0.05% of it), against ``pi / (4 beta)`` and the rigid-block
    chain's largest."""
    import melange_ti
    import melange_ti.scene
    from melange_ti.io.hdf5 import read_run

    work = Path(work or tempfile.mkdtemp())
    beta = beta_of(E, t)
    n = int(math.ceil(length / beta / b)) + 1
    delta = P / (R * b)
    text = slab(n, b, t, delta, E=E, duration=settle_time, drag=1.0, zeta=0.05, loaded=0, layers=layers)
    first = work / f"edge_{b:g}_{t:g}_{E:g}_{layers}.h5"
    melange_ti.run(melange_ti.scene.loads(text), out=str(first), overwrite=True)
    sig, xb, across = settled_stresses(first)
    strength = 0.9995 * float(sig.max())
    restart = text.split("[[iceberg]]")[0].replace(f"tensile_strength = {UNBREAKABLE!r}", f"tensile_strength = {strength!r}")
    restart = restart.replace(f"duration = {settle_time!r}", "duration = 1.0")
    restart += f'\n[start]\nfile = "{first}"\ntime = {settle_time!r}\n'
    second = work / f"edge_break_{b:g}_{t:g}_{E:g}_{layers}.h5"
    melange_ti.run(melange_ti.scene.loads(restart), out=str(second), overwrite=True)
    bt = np.asarray(read_run(str(second))["bonds"]["break_time"])
    broke = np.flatnonzero(bt == np.nanmin(bt)) if np.isfinite(bt).any() else np.array([], dtype=np.int64)
    _, sig_d, x_d = discrete_static(n, b, t, delta, E, loaded=0)
    peak = edge_peak(E, t)
    x_break = float(xb[broke].mean()) if broke.size else float("nan")
    far = float(xb[broke][np.argmax(np.abs(xb[broke] - peak))]) if broke.size else float("nan")
    return dict(
        width=b,
        thickness=t,
        layers=layers,
        bond_modulus=E,
        one_over_beta=1.0 / beta,
        blocks=n,
        blocks_per_peak_distance=peak / b,
        peak_theory=peak,
        peak_discrete=float(x_d[np.argmax(sig_d)]),
        peak_model=float(xb[np.argmax(sig)]),
        first_breaks_across_joints=int(np.sum(across[broke])),
        first_break_x=x_break,
        first_breaks=int(broke.size),
        first_break_x_min=float(xb[broke].min()) if broke.size else float("nan"),
        first_break_x_max=float(xb[broke].max()) if broke.size else float("nan"),
        first_fragment_width=x_break + 0.5 * b,
        error_in_cells=(far - peak) / b,
        stress_model_over_discrete=float(sig.max() / sig_d.max()),
    )


def edge_study(out_dir: Path, work=None):
    """The first break under a load at the free edge against ``pi / (4 beta)``: at three
    block widths (the default slab), and at two thicknesses and two moduli (``b = 0.25``)."""
    rows = []
    cases = [(b, 1.0, E0, 1) for b in (0.5, 0.25, 0.125)] + [(0.25, 0.5, E0, 1), (0.25, 1.0, 16 * E0, 1), (0.25, 0.5, 16 * E0, 1)]
    cases += [(0.25, 1.0, E0, 2), (0.125, 1.0, E0, 2)]  # the slab as two layers of cells
    for b, t, E, layers in cases:
        row = edge_run(b, t, E, work=work, layers=layers)
        rows.append(row)
        print(
            f"edge b={b:g} t={t:g} E={E / E0:g}xE0 layers={layers}: first break at x = {row['first_break_x_min']:.4f}-"
            f"{row['first_break_x_max']:.4f} ({row['first_breaks']} bond(s)) vs pi/(4 beta) = {row['peak_theory']:.4f} "
            f"(farthest {row['error_in_cells']:+.2f} cells); "
            f"chain's peak {row['peak_discrete']:.4f}, model's {row['peak_model']:.4f}",
            flush=True,
        )
    write_csv(out_dir / "edge.csv", rows)
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    peaks = np.array([r["peak_theory"] for r in rows])
    ax.plot([0, peaks.max() * 1.15], [0, peaks.max() * 1.15], "k-", lw=1, label="x = pi / (4 beta)")
    for r, mk in zip(rows, "os^Dv<PX", strict=True):
        ax.errorbar(
            r["peak_theory"],
            r["first_break_x"],
            yerr=r["width"],
            fmt=mk,
            mfc="none",
            capsize=3,
            label=f"b = {r['width']:g}, t = {r['thickness']:g}, E = {r['bond_modulus'] / E0:g} x default, "
            f"{r['layers']} layer{'s' if r['layers'] > 1 else ''}",
        )
    ax.set(
        xlabel="pi / (4 beta) (w)",
        ylabel="first broken bond's distance from the load (w)",
        title="a floating slab loaded at its free edge: where it breaks first (bars: one block)",
    )
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out_dir / "edge.png", dpi=120)


def write_csv(path: Path, rows: list[dict]) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("check", choices=("hetenyi", "modes", "breaking", "edge", "all"))
    p.add_argument("--out", default="validation/results/bonds")
    a = p.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as work:
        if a.check in ("hetenyi", "all"):
            hetenyi_study(out, work=work)
        if a.check in ("modes", "all"):
            modes_study(out, work=work)
        if a.check in ("breaking", "all"):
            breaking_study(out, work=work)
        if a.check in ("edge", "all"):
            edge_study(out, work=work)


if __name__ == "__main__":
    sys.exit(main())
