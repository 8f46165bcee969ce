"""The paper's claim in closed loop (issue 33 part 2): does a Gaussian camera at the effective read
noise predict an AO loop's residual when the real camera is a *fixed* per-pixel sCMOS map?

OOPAO: 8 m telescope, 16x16 sub-apertures of 8x8 px (pixel lambda/d, OOPAO's sinc^2 spot), a
one-layer frozen-flow atmosphere at a fixed seed, a 17x17 Fried DM, one zonal reconstructor, an
integrator (gain 0.3, one frame of delay), ~50 photons per full sub-aperture per frame. Slopes
come from our own subtract-and-clip centre of gravity, max(x - b, 0), on the camera's frames
(not OOPAO's centroider: its threshold is a fraction of the frame's maximum and is not
subtracted); b is each camera's own optimum from `detnoise.simulate` at the matched spot.

Every camera is `detnoise.ao.oopao.DetnoiseDetector` (OOPAO's Detector reading through a
`detnoise.Readout`). The measured camera is one 128x128 per-pixel read-noise map drawn once from the paper's pdf (Basden 2015
Eq. 3, detnoise's `scmos-fixed` pattern). Cases, all on the same atmosphere and the same
photon-noise and read-noise random streams (the camera's seed and frame counter):
  a   the map (`scmos-map` of it), reference slopes taken without noise
  a'  the map, reference slopes averaged over noisy flat-wavefront frames through it
  b   a Gaussian camera at the map's median
  c   a Gaussian camera at sigma_random_e of `detnoise.effective` for this map, spot, flux
  d   photon noise only

Run from the repository root:

    python examples/closed_loop/closed_loop.py OUT_DIR [--quick]

It writes OUT_DIR/results.json, results.csv, differences.csv, closed_loop.png/.svg,
noise_map_e.fits and static_aberration_nm.fits (a folder it wrote before is replaced; any other
existing folder is refused).
"""

import argparse
import contextlib
import csv
import io
import json
import os
import shutil
import signal
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

MARKER = ".detnoise-closed-loop"
CASES = ["a", "a'", "b", "c", "d"]
LABELS = {
    "a": "a: measured map, noiseless refs",
    "a'": "a': measured map, refs through the camera",
    "b": "b: Gaussian at the map's median",
    "c": "c: Gaussian at sigma_random",
    "d": "d: photon noise only",
}


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out", type=Path, help="output folder (created; replaced only if this script wrote it)")
    p.add_argument("--quick", action="store_true", help="the CI version: 0.7 s of loop, 5 segments, fewer reference frames")
    p.add_argument("--seconds", type=float, default=None, help="loop time measured after settling, s (default 10; --quick 0.6)")
    p.add_argument("--rate-hz", type=float, default=1000.0, help="frame rate, Hz (default 1000)")
    p.add_argument("--settle-s", type=float, default=None, help="loop time discarded first, s (default 0.5; --quick 0.1)")
    p.add_argument("--segments", type=int, default=None, help="independent segments of the measured time (default 10; --quick 5)")
    p.add_argument("--photons", type=float, default=50.0, help="photons per full sub-aperture per frame (default 50)")
    p.add_argument("--gain", type=float, default=0.3, help="integrator gain (default 0.3)")
    p.add_argument("--ref-frames", type=int, default=None, help="noisy flat frames averaged for a' (default 4000; --quick 1000)")
    p.add_argument("--threshold-e", type=float, default=None,
                   help="one CoG threshold b for every case, e- (default: each camera's optimum from detnoise.simulate)")
    p.add_argument("--seed", type=int, default=2015, help="camera noise seed (photon and read noise), shared by all cases")
    p.add_argument("--pattern-seed", type=int, default=33, help="seed of the 128x128 read-noise map drawn from the paper's pdf")
    p.add_argument("--r0-m", type=float, default=0.15, help="Fried parameter at 500 nm, m (default 0.15)")
    p.add_argument("--wind-m-per-s", type=float, default=10.0, help="wind speed of the single layer, m/s (default 10)")
    a = p.parse_args(argv)
    quick = a.quick
    a.seconds = a.seconds if a.seconds is not None else (0.6 if quick else 10.0)
    a.settle_s = a.settle_s if a.settle_s is not None else (0.1 if quick else 0.5)
    a.segments = a.segments if a.segments is not None else (5 if quick else 10)
    a.ref_frames = a.ref_frames if a.ref_frames is not None else (1000 if quick else 4000)
    if a.segments < 2:
        p.error("--segments: at least 2 (the standard errors come from the segments)")
    if a.gain <= 0 or a.gain >= 2:
        p.error("--gain: in (0, 2)")
    if a.photons <= 0:
        p.error("--photons: > 0")
    return a


# ----------------------------------------------------------------------------- output folder
def check_out(out: Path):
    """Refuse an existing folder this script did not write, before any long work."""
    if out.exists() and not (out / MARKER).is_file():
        raise SystemExit(
            f"error: {out} exists and was not written by closed_loop.py (no {MARKER}): "
            "choose another folder or remove it"
        )
    parent = out.resolve().parent
    if not parent.is_dir():
        raise SystemExit(f"error: {parent} (the parent of {out}) is not a directory")


def publish(tmp: Path, out: Path):
    """Move the finished temporary folder into place (replacing an older run of this script)."""
    check_out(out)
    if out.exists():
        old = out.with_name(out.name + f".old-{os.getpid()}")
        out.rename(old)
        tmp.rename(out)
        shutil.rmtree(old)
    else:
        tmp.rename(out)


# ----------------------------------------------------------------------------- the camera
def paper_map(pattern_seed, n=128):
    """An n x n per-pixel read-noise map (e-) drawn once from the paper's pdf: detnoise's
    `scmos-fixed` pattern, read out exactly as (sigma z) / z on the same normal deviates."""
    import detnoise

    zero = np.zeros((n, n))
    sz = detnoise.Readout("scmos-fixed", pattern_seed=pattern_seed).read(zero, seed=1, photon_noise=False)
    z = detnoise.Readout("scmos-constant:1").read(zero, seed=1, photon_noise=False)
    assert np.all(z != 0)
    return sz / z


def make_camera(readout, noisy=True):
    """OOPAO's Shack-Hartmann detector reading its frames through `readout` (detnoise.ao.oopao);
    noisy=False: the noise-free frame (expected photo-electrons, QE 1)."""
    from detnoise.ao.oopao import DetnoiseDetector

    with contextlib.redirect_stdout(io.StringIO()):
        return DetnoiseDetector(readout, photonNoise=noisy, readoutNoise=noisy)


# ----------------------------------------------------------------------------- centroids
def subapertures(frame, nsub, npx):
    """(nsub n, nsub n) frame -> (nsub^2, n, n), lenslet i * nsub + j (OOPAO's order)."""
    return frame.reshape(nsub, npx, nsub, npx).transpose(0, 2, 1, 3).reshape(nsub * nsub, npx, npx)


def cog(images, b):
    """Subtract-and-clip centre of gravity of max(x - b, 0), px from each sub-aperture's centre
    ((n-1)/2): (k, 2) as (row, column); an image with nothing above b reads as the centre."""
    n = images.shape[-1]
    w = np.clip(images - b, 0.0, None)
    u = np.arange(n) - (n - 1) / 2.0
    total = w.sum(axis=(1, 2))
    safe = np.where(total > 0, total, 1.0)
    row = (w.sum(axis=2) * u).sum(axis=1) / safe
    col = (w.sum(axis=1) * u).sum(axis=1) / safe
    return np.stack([np.where(total > 0, row, 0.0), np.where(total > 0, col, 0.0)], axis=1)


# ----------------------------------------------------------------------------- spot matching
def pixel_gauss(s, n=8):
    from scipy.special import erf

    edges = np.arange(n + 1) - n / 2.0
    g = np.diff(0.5 * (1 + erf(edges / (np.sqrt(2) * s))))
    img = np.outer(g, g)
    return img / img.sum()


def pixel_airy(d, n=8, fine=16):
    from scipy.special import j1

    u = (np.arange(n * fine) + 0.5) / fine - n / 2.0
    x, y = np.meshgrid(u, u)
    v = 3.8317 * np.hypot(x, y) / (d / 2.0)
    v = np.where(v == 0, 1e-12, v)
    img = ((2 * j1(v) / v) ** 2).reshape(n, fine, n, fine).sum(axis=(1, 3))
    return img / img.sum()


def match_spot(mean_spot):
    """The detnoise spot (airy:D or gauss:S,S, pixel-integrated, centred as OOPAO's spot) closest
    to the loop's mean noiseless spot in least squares; returns (spec, rms misfit / peak)."""
    target = mean_spot / mean_spot.sum()
    best = []
    for d in np.arange(1.0, 4.0001, 0.05):
        best.append((np.sum((pixel_airy(d) - target) ** 2), f"airy:{d:.2f}"))
    for s in np.arange(0.2, 1.5001, 0.01):
        best.append((np.sum((pixel_gauss(s) - target) ** 2), f"gauss:{s:.2f},{s:.2f}"))
    err, spec = min(best)
    return spec, float(np.sqrt(err / target.size) / target.max())


# ----------------------------------------------------------------------------- the system
class System:
    """OOPAO telescope, source, atmosphere, DM and Shack-Hartmann, and the zonal reconstructor."""

    def __init__(self, args):
        from OOPAO.Atmosphere import Atmosphere
        from OOPAO.DeformableMirror import DeformableMirror
        from OOPAO.ShackHartmann import ShackHartmann
        from OOPAO.Source import Source
        from OOPAO.Telescope import Telescope

        self.nsub, self.npx = 16, 8
        with contextlib.redirect_stdout(io.StringIO()):
            self.tel = Telescope(resolution=self.nsub * 8, diameter=8.0, samplingTime=1.0 / args.rate_hz)
            self.ngs = Source("I", 8.0)
            d = self.tel.D / self.nsub
            self.ngs.nPhoton = args.photons / (self.tel.samplingTime * d * d)
            self.ngs * self.tel
            self.atm = Atmosphere(self.tel, r0=args.r0_m, L0=25.0, windSpeed=[args.wind_m_per_s],
                                  fractionalR0=[1.0], windDirection=[0.0], altitude=[0.0])
            self.atm.initializeAtmosphere(self.tel)
            self.dm = DeformableMirror(self.tel, nSubap=self.nsub, mechCoupling=0.35, print_dm_properties=False)
            self.wfs = ShackHartmann(nSubap=self.nsub, telescope=self.tel, lightRatio=0.5, shannon_sampling=False)
        self.pupil = self.tel.pupil.astype(bool)
        self.valid = np.asarray(self.wfs.valid_subapertures_1D, dtype=bool)
        import detnoise

        self.noiseless = make_camera(detnoise.Readout("scmos-constant:0"), noisy=False)
        flat = self.frame(np.zeros(self.pupil.shape), self.noiseless)
        flux = subapertures(flat, self.nsub, self.npx).sum(axis=(1, 2))
        self.flux_full = float(flux.max())
        self.flat = flat

    def frame(self, opd_m, camera):
        """The camera's frame (e-) for a residual OPD (m) over the pupil."""
        self.wfs.cam = camera
        self.ngs ** self.tel
        self.ngs.OPD = opd_m * self.pupil
        with contextlib.redirect_stdout(io.StringIO()):
            self.ngs * self.wfs
        return np.asarray(camera.frame, dtype=float)

    def slopes(self, frame, b):
        """Slopes (px) of the valid sub-apertures, [rows..., columns...]."""
        c = cog(subapertures(frame, self.nsub, self.npx)[self.valid], b)
        return np.concatenate([c[:, 0], c[:, 1]])

    def dm_opd(self, cmd):
        return (self.dm.modes @ cmd).reshape(self.pupil.shape)

    def calibrate(self, push_m=10e-9, rcond=0.05):
        """Zonal interaction matrix (px per m, push-pull, noiseless frames, plain CoG b = 0) and
        its truncated pseudo-inverse (singular values below rcond x the largest dropped)."""
        n_act = self.dm.modes.shape[1]
        cols = []
        for k in range(n_act):
            opd = self.dm.modes[:, k].reshape(self.pupil.shape) * push_m
            sp = self.slopes(self.frame(opd, self.noiseless), 0.0)
            sm = self.slopes(self.frame(-opd, self.noiseless), 0.0)
            cols.append((sp - sm) / (2 * push_m))
        im = np.array(cols).T
        u, s, vt = np.linalg.svd(im, full_matrices=False)
        keep = s > rcond * s[0]
        self.reconstructor = (vt[keep].T / s[keep]) @ u[:, keep].T
        self.n_modes = int(keep.sum())
        return im

    def phase_rms_nm(self, opd_m):
        v = opd_m[self.pupil]
        return float(np.std(v) * 1e9)


# ----------------------------------------------------------------------------- statistics
def mean_se(x):
    x = np.asarray(x, dtype=float)
    return float(x.mean()), float(x.std(ddof=1) / np.sqrt(len(x)))


def run(args, tmp: Path, log=print):
    import detnoise

    t_wall, t_cpu = time.perf_counter(), time.process_time()
    rate = args.rate_hz
    n_settle = int(round(args.settle_s * rate))
    n_meas = int(round(args.seconds * rate))
    n_meas -= n_meas % args.segments
    n_frames = n_settle + n_meas

    noise_map = paper_map(args.pattern_seed)
    median_e = float(np.median(noise_map))
    sys_ = System(args)
    log(f"OOPAO: {int(sys_.valid.sum())} valid sub-apertures, {sys_.dm.modes.shape[1]} actuators, "
        f"{sys_.flux_full:.1f} photons in a full sub-aperture")
    sys_.calibrate()
    log(f"reconstructor: {sys_.n_modes} modes kept")

    # The loop's own spot: a short noiseless closed loop, mean image of the full sub-apertures.
    spot_frames = 150 if args.quick else 400
    full = subapertures(sys_.flat, sys_.nsub, sys_.npx).sum(axis=(1, 2)) > 0.95 * sys_.flux_full
    cmd = np.zeros(sys_.dm.modes.shape[1])
    acc = np.zeros((sys_.npx, sys_.npx))
    for t in range(spot_frames):
        sys_.atm.update()
        opd = sys_.atm.OPD - sys_.dm_opd(cmd)
        f = sys_.frame(opd, sys_.noiseless)
        cmd += args.gain * (sys_.reconstructor @ sys_.slopes(f, 0.0))
        if t >= spot_frames // 3:
            acc += subapertures(f, sys_.nsub, sys_.npx)[full].sum(axis=0)
    spot, misfit = match_spot(acc)
    log(f"matched spot {spot} (rms misfit {misfit:.3f} of the peak)")
    calibrated = sys_
    sys_ = System(args)  # a fresh atmosphere (same seed) for the runs, the same optics
    sys_.reconstructor, sys_.n_modes = calibrated.reconstructor, calibrated.n_modes

    eff_iters = 4000 if args.quick else 20000
    eff = detnoise.effective("scmos-map", map_e=noise_map, subap_px=sys_.npx, spot=spot,
                             signal_photons=args.photons, iters=eff_iters, seed=1)[0]
    sigma_random = float(eff["sigma_random_e"])
    log(f"effective: sigma_eff {eff['sigma_eff_e']:.3f} e-, sigma_random {sigma_random:.3f} "
        f"+- {eff['sigma_random_se_e']:.3f} e-, median {median_e:.3f} e-")
    models = {"a": "scmos-map", "b": f"scmos-constant:{median_e:.6f}",
              "c": f"scmos-constant:{sigma_random:.6f}", "d": "scmos-constant:0"}
    sims = detnoise.simulate(list(models.values()), map_e=noise_map, subap_px=sys_.npx, spot=spot,
                             signal_photons=args.photons, iters=eff_iters, seed=1)
    b_opt = {k: float(r["b_opt_e"]) for k, r in zip(models, sims)}
    b_opt["a'"] = b_opt["a"]
    if args.threshold_e is not None:
        b_opt = {k: float(args.threshold_e) for k in CASES}
    r_px = {k: (float(r["r_px"]), float(r["r_se_px"])) for k, r in zip(models, sims)}
    log("thresholds b (e-): " + ", ".join(f"{k} {v:g}" for k, v in b_opt.items()))

    def readout(case, seed):
        m = models["a" if case == "a'" else case]
        return detnoise.Readout(m, map_e=noise_map, seed=seed) if m == "scmos-map" else detnoise.Readout(m, seed=seed)

    # References. The flat-wavefront spots are centro-symmetric, so a noiseless reference is the
    # centre whatever b; a' averages noisy flat frames through the map (its own seed).
    refs = {k: sys_.slopes(sys_.flat, b_opt[k]) for k in CASES}
    ref_cam = make_camera(readout("a", args.seed + 1))
    flat_slopes = np.empty((args.ref_frames, len(refs["a"])))
    for i in range(args.ref_frames):
        ref_cam.integrate(sys_.flat)
        flat_slopes[i] = sys_.slopes(np.asarray(ref_cam.frame, dtype=float), b_opt["a"])
    refs["a'"] = flat_slopes.mean(axis=0)
    bias = refs["a'"] - refs["a"]  # the camera's mean slope bias at flat wavefront, px
    half = args.ref_frames // 2
    bias_h = [flat_slopes[:half].mean(axis=0) - refs["a"], flat_slopes[half:2 * half].mean(axis=0) - refs["a"]]
    static_opd = sys_.dm_opd(sys_.reconstructor @ bias)
    static_nm = sys_.phase_rms_nm(static_opd)
    static_noise_nm = sys_.phase_rms_nm(sys_.dm_opd(sys_.reconstructor @ (bias_h[0] - bias_h[1]))) / 2
    log(f"static slope bias rms {np.sqrt(np.mean(bias ** 2)):.3f} px (max {np.abs(bias).max():.2f}); "
        f"static aberration {static_nm:.1f} nm rms (reference noise {static_noise_nm:.1f} nm)")

    # The loop: all cases in lockstep on one atmosphere, frame t read as frame t of one seed.
    cams = {k: make_camera(readout(k, args.seed)) for k in CASES}
    cmds = {k: np.zeros(sys_.dm.modes.shape[1]) for k in CASES}
    wfe = {k: np.zeros(n_frames) for k in CASES}
    mean_res = {k: np.zeros(sys_.pupil.shape) for k in CASES}
    # Each camera's centroid response in the loop along the static pattern (its "optical gain"
    # against the noise-free calibration): every few frames each case's residual is read +- 10 nm
    # rms of the pattern through a probe camera of that readout (own seed, up and down on the
    # same deviates), through the reconstructor, projected on the pattern's command.
    probe = static_opd * (10.0 / max(sys_.phase_rms_nm(static_opd), 1e-9))  # m, 10 nm rms
    probe_cmd = sys_.reconstructor @ bias
    probe_scale = sys_.phase_rms_nm(static_opd) / 10.0 / (probe_cmd @ probe_cmd)
    probe_cams = {k: make_camera(readout(k, args.seed + 2)) for k in CASES if k != "a'"}
    probe_every = 25
    gains = {k: [] for k in probe_cams}
    t_loop = time.perf_counter()
    for t in range(n_frames):
        sys_.atm.update()
        atm = sys_.atm.OPD.copy()
        for k in CASES:
            res = atm - sys_.dm_opd(cmds[k])
            wfe[k][t] = sys_.phase_rms_nm(res)
            if t >= n_settle:
                mean_res[k] += res
            cams[k].detnoise_readout.frame = t  # frame t of the one seed, in every case
            if k in probe_cams and t >= n_settle and t % probe_every == 0:
                pc = probe_cams[k]
                pc.detnoise_readout.frame = t
                up = sys_.slopes(sys_.frame(res + probe, pc), b_opt[k])
                pc.detnoise_readout.frame = t
                down = sys_.slopes(sys_.frame(res - probe, pc), b_opt[k])
                gains[k].append(float(probe_cmd @ (sys_.reconstructor @ (up - down)) / 2 * probe_scale))
            f = sys_.frame(res, cams[k])
            cmds[k] += args.gain * (sys_.reconstructor @ (sys_.slopes(f, b_opt[k]) - refs[k]))
        if (t + 1) % max(1, n_frames // 10) == 0:
            log(f"frame {t + 1}/{n_frames} ({time.perf_counter() - t_loop:.0f} s): "
                + ", ".join(f"{k} {np.sqrt(np.mean(wfe[k][max(0, t - 99):t + 1] ** 2)):.0f}" for k in CASES) + " nm")
    loop_s = time.perf_counter() - t_loop

    # Segment statistics: residual per segment = sqrt(mean of the frames' variance), nm.
    seg = {k: np.sqrt((wfe[k][n_settle:] ** 2).reshape(args.segments, -1).mean(axis=1)) for k in CASES}
    loop_static_opd = (mean_res["a"] - mean_res["a'"]) / n_meas
    loop_static_nm = sys_.phase_rms_nm(loop_static_opd)
    # Is the loop's static map the flat-wavefront one, scaled? (least-squares scale, correlation)
    fl, lp = static_opd[sys_.pupil], loop_static_opd[sys_.pupil]
    fl, lp = fl - fl.mean(), lp - lp.mean()
    loop_scale = float(fl @ lp / (fl @ fl))
    loop_corr = float(fl @ lp / np.sqrt((fl @ fl) * (lp @ lp)))
    rows = []
    for k in CASES:
        m, se = mean_se(seg[k])
        sigma = {"a": None, "a'": None, "b": median_e, "c": sigma_random, "d": 0.0}[k]
        rows.append({
            "case": k, "camera": LABELS[k].split(": ", 1)[1], "model": models["a" if k == "a'" else k],
            "read_noise_e": sigma, "reference": "through the camera" if k == "a'" else "noiseless",
            "threshold_b_e": b_opt[k], "r_mc_px": r_px["a" if k == "a'" else k][0],
            "r_mc_se_px": r_px["a" if k == "a'" else k][1],
            "residual_nm": m, "residual_se_nm": se,
            "optical_gain": float(np.mean(gains["a" if k == "a'" else k])),
            "optical_gain_se": float(np.std(gains["a" if k == "a'" else k], ddof=1) / np.sqrt(len(gains["a" if k == "a'" else k]))),
        })
    diffs = []
    for x, y in [("a", "c"), ("a'", "c"), ("a", "a'"), ("a", "b"), ("b", "d"), ("c", "d")]:
        m, se = mean_se(seg[x] - seg[y])
        diffs.append({"difference": f"{x} - {y}", "value_nm": m, "se_nm": se})
    q, q_se = mean_se(seg["a"] ** 2 - seg["a'"] ** 2)
    quad = {
        "a2_minus_ap2_nm2": q, "a2_minus_ap2_se_nm2": q_se,
        "static_flat_nm": static_nm, "static_flat2_nm2": static_nm ** 2,
        "static_reference_noise_nm": static_noise_nm,
        "static_in_loop_nm": loop_static_nm, "static_in_loop2_nm2": loop_static_nm ** 2,
        "in_loop_over_flat_scale": loop_scale, "in_loop_flat_correlation": loop_corr,
        "static_flat_over_gain_a_nm": static_nm / float(np.mean(gains["a"])),
    }
    result = {
        "setup": {
            "simulator": "OOPAO", "telescope_diameter_m": 8.0, "subapertures": sys_.nsub,
            "subaperture_px": sys_.npx, "frame_px": sys_.nsub * sys_.npx,
            "valid_subapertures": int(sys_.valid.sum()), "actuators": int(sys_.dm.modes.shape[1]),
            "reconstructor_modes": sys_.n_modes, "pixel_scale": "lambda/d (OOPAO shannon_sampling=False)",
            "wfs_band": "I", "photons_per_full_subaperture": sys_.flux_full, "integrator_gain": args.gain,
            "delay_frames": 1, "frame_rate_hz": rate, "settle_s": n_settle / rate, "measured_s": n_meas / rate,
            "segments": args.segments, "segment_s": n_meas / rate / args.segments,
            "r0_500nm_m": args.r0_m, "L0_m": 25.0, "wind_m_per_s": args.wind_m_per_s, "layers": 1,
            "camera_seed": args.seed, "pattern_seed": args.pattern_seed, "reference_frames": args.ref_frames,
            "centroider": "own subtract-and-clip CoG max(x - b, 0) on the camera frames, b "
                          + ("per camera from detnoise.simulate" if args.threshold_e is None else "fixed by --threshold-e"),
            "spot": spot, "spot_misfit_of_peak": misfit, "quick": bool(args.quick),
        },
        "map": {"median_e": median_e, "mean_e": float(noise_map.mean()),
                "rms_e": float(np.sqrt(np.mean(noise_map ** 2))), "max_e": float(noise_map.max()),
                "fraction_above_3x_median": float(np.mean(noise_map > 3 * median_e))},
        "effective": {k: eff[k] for k in ("sigma_eff_e", "sigma_eff_se_e", "sigma_random_e", "sigma_random_se_e",
                                           "static_px", "static_se_px", "random_rms_px", "r_px", "r_se_px")},
        "static_slope_bias": {"rms_px": float(np.sqrt(np.mean(bias ** 2))), "max_abs_px": float(np.abs(bias).max())},
        "cases": rows, "differences": diffs, "quadrature": quad,
        "segments_nm": {k: seg[k].tolist() for k in CASES},
        "time": {"loop_wall_s": loop_s, "total_wall_s": time.perf_counter() - t_wall,
                 "total_cpu_s": time.process_time() - t_cpu, "cpus": os.cpu_count(),
                 "load_average_1min": os.getloadavg()[0]},
    }
    write_outputs(tmp, result, noise_map, static_opd, wfe, n_settle, rate, sys_.pupil)
    return result


def write_outputs(tmp, result, noise_map, static_opd, wfe, n_settle, rate, pupil):
    from astropy.io import fits

    (tmp / MARKER).write_text("written by examples/closed_loop/closed_loop.py\n")
    fits.PrimaryHDU(noise_map.astype(np.float64)).writeto(tmp / "noise_map_e.fits")
    hdu = fits.PrimaryHDU(np.where(pupil, static_opd * 1e9, np.nan))
    hdu.header["BUNIT"] = "nm"
    hdu.writeto(tmp / "static_aberration_nm.fits")
    (tmp / "results.json").write_text(json.dumps(result, indent=2) + "\n")
    with open(tmp / "results.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(result["cases"][0]))
        w.writeheader()
        w.writerows(result["cases"])
    with open(tmp / "differences.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=["difference", "value_nm", "se_nm"])
        w.writeheader()
        w.writerows(result["differences"])
    figure(tmp, result, static_opd, wfe, n_settle, rate, pupil)


def figure(tmp, result, static_opd, wfe, n_settle, rate, pupil):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colors = {"a": "C3", "a'": "C1", "b": "C2", "c": "C0", "d": "C7"}
    fig, ax = plt.subplots(1, 3, figsize=(16, 4.8), gridspec_kw={"width_ratios": [1.5, 1, 1]})
    block = max(1, int(rate * 0.05))
    for k in CASES:
        x = wfe[k]
        n = len(x) // block * block
        t = (np.arange(n // block) + 0.5) * block / rate
        ax[0].plot(t, np.sqrt((x[:n] ** 2).reshape(-1, block).mean(axis=1)), color=colors[k], lw=1, label=LABELS[k])
    ax[0].axvline(n_settle / rate, color="k", ls=":", lw=1, label="end of settling")
    ax[0].set_xlabel("time (s)")
    ax[0].set_ylabel(f"residual wavefront error (nm rms, {1000 * block / rate:.0f} ms means)")
    lo = min(r["residual_nm"] for r in result["cases"])
    ax[0].set_ylim(0.7 * lo, 1.6 * max(r["residual_nm"] for r in result["cases"]))
    ax[0].legend(fontsize=8, loc="upper right")
    ax[0].set_title("closed loop, all cases on one atmosphere")
    for i, r in enumerate(result["cases"]):
        k = r["case"]
        ax[1].errorbar(i, r["residual_nm"], yerr=r["residual_se_nm"], fmt="o", color=colors[k], capsize=4,
                       label=f"{k}: {r['residual_nm']:.1f} ± {r['residual_se_nm']:.1f} nm")
        ax[1].plot(np.full(len(result["segments_nm"][k]), i) + 0.15, result["segments_nm"][k], ".",
                   color=colors[k], alpha=0.4, ms=3)
    ax[1].set_xticks(range(len(CASES)), CASES)
    ax[1].set_xlabel("case (dots: segment means)")
    ax[1].set_ylabel("residual wavefront error (nm rms, mean ± SE)")
    ax[1].legend(fontsize=8)
    ax[1].set_title("residual per case")
    img = np.where(pupil, static_opd * 1e9, np.nan)
    lim = np.nanmax(np.abs(img))
    im = ax[2].imshow(img, cmap="RdBu_r", vmin=-lim, vmax=lim, origin="lower")
    ax[2].set_xlabel("pupil x (px, 6.25 cm)")
    ax[2].set_ylabel("pupil y (px, 6.25 cm)")
    ax[2].set_title(f"static aberration of the map: {result['quadrature']['static_flat_nm']:.0f} nm rms")
    fig.colorbar(im, ax=ax[2], label="OPD (nm)")
    fig.tight_layout()
    fig.savefig(tmp / "closed_loop.png", dpi=110)
    fig.savefig(tmp / "closed_loop.svg")
    plt.close(fig)


def main(argv=None, log=print):
    args = parse_args(argv)
    check_out(args.out)  # before any long work
    parent = args.out.resolve().parent
    tmp = Path(tempfile.mkdtemp(prefix=f".{args.out.name}.tmp-", dir=parent))
    # a killed run (SIGTERM) removes its temporary folder too
    previous = signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    try:
        result = run(args, tmp, log=log)
        publish(tmp, args.out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    finally:
        signal.signal(signal.SIGTERM, previous)
    t = result["time"]
    log(f"wrote {args.out}: loop {t['loop_wall_s']:.0f} s, total {t['total_wall_s']:.0f} s wall, "
        f"{t['total_cpu_s']:.0f} s CPU")
    return result


if __name__ == "__main__":
    main()
    sys.exit(0)
