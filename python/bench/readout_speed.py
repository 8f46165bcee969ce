"""CPU nanoseconds per pixel of `Readout.read` on a 256 x 256 frame, to compare with the
engine's per pixel-frame cost (`cargo bench --bench engine`).

    python python/bench/readout_speed.py [repeats]

The frame is a Shack-Hartmann frame as the engine simulates one: 16 x 16 sub-apertures of
16 x 16 px, each with a centred Airy-like spot (a Gaussian of sigma 0.9 px) holding
S = 50 photo-electrons, read as one (256, 256) frame and as a (256, 16, 16) stack, with and
without shot noise. Each figure is the best of `repeats` runs of the process's CPU time (all
threads) per pixel, so other load on the machine inflates it less; wall time is shown too.
"""

import sys
import time

import numpy as np

import detnoise


def sh_frame():
    y, x = np.mgrid[:16, :16] - 7.5
    spot = np.exp(-(x**2 + y**2) / (2 * 0.9**2))
    spot *= 50.0 / spot.sum()
    stack = np.broadcast_to(spot, (256, 16, 16)).copy()
    frame = stack.reshape(16, 16, 16, 16).transpose(0, 2, 1, 3).reshape(256, 256).copy()
    return frame, stack


def best_ns_per_pixel(read, image, repeats):
    read(image)  # builds the model for this size
    cpu, wall = [], []
    for _ in range(repeats):
        c, w = time.process_time(), time.perf_counter()
        for _ in range(10):
            read(image)
        cpu.append((time.process_time() - c) / 10)
        wall.append((time.perf_counter() - w) / 10)
    return min(cpu) / image.size * 1e9, min(wall) / image.size * 1e9


def main():
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    frame, stack = sh_frame()
    rng = np.random.default_rng(7)
    map_e = rng.lognormal(np.log(0.8), 0.5, (256, 256))
    models = [
        ("scmos-map", {"map_e": map_e}),
        ("emccd-stochastic", {}),
        ("scmos-constant:1", {}),
        ("scmos-random", {}),
    ]
    print(f"{'model':>18} {'input':>16} {'shot noise':>10} {'CPU ns/px':>10} {'wall ns/px':>10}")
    for name, params in models:
        cam = detnoise.Readout(name, **params)
        for label, image in (("frame 256x256", frame), ("stack 256x16x16", stack)):
            for shot in (True, False):
                data = image if shot else np.round(image)
                cpu, wall = best_ns_per_pixel(
                    lambda x: cam.read(x, photon_noise=shot), data, repeats
                )
                print(f"{name:>18} {label:>16} {str(shot):>10} {cpu:10.1f} {wall:10.1f}")


if __name__ == "__main__":
    main()
