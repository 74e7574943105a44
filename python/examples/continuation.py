"""The continuation diagram of the lab's bicycle with its rides, from data/: the Whipple
model's eigenvalues against speed (real parts, and the weave's imaginary part), the self-stable
range shaded, and each ride's measured weave eigenvalue with its standard errors at its speed.

Everything computed comes from bikeproc's core; this script only draws. Needs matplotlib
(``pip install './python[examples]'``). Runs without a display and writes OUT.png, by default
``continuation.png`` in the folder it is run from:

    python python/examples/continuation.py [OUT.png]
"""

import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import bikeproc  # noqa: E402

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"
out = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "continuation.png").resolve()

bike = bikeproc.Bicycle.from_file(DATA / "lab_bike.toml")
speeds = np.linspace(0.0, 10.0, 2001)
eigenvalues = bike.eigenvalues(speeds)
rides = bikeproc.dynamic(DATA / "rides.toml")["rides"]

fig, ax = plt.subplots(figsize=(9, 5.5))
for low_high in bike.stable_range():
    high = low_high["high_mps"] if low_high["high_mps"] is not None else speeds[-1]
    ax.axvspan(low_high["low_mps"], high, color="0.92", label="self-stable")
styles = {"Weave": "C0", "WeaveConjugate": "C0", "Capsize": "C1", "Castor": "C2"}
for k, mode in enumerate(bike.modes):
    if mode in styles:
        name = "Weave" if mode == "WeaveConjugate" else mode  # two real roots below ~0.5 m/s
        ax.plot(speeds, eigenvalues[:, k].real, color=styles[mode], label=f"{name}: real part")
weave = bike.modes.index("Weave")
ax.plot(speeds, eigenvalues[:, weave].imag, "--", color="C0", label="Weave: imaginary part")

v = np.array([r["speed_mps"] for r in rides])
v_se = np.array([r["speed_se_mps"] for r in rides])
for part, marker, colour in [("re", "o", "C3"), ("im", "s", "C4")]:
    value = np.array([r["weave"][part] for r in rides])
    se = np.array([r["weave"][f"{part}_se"] for r in rides])
    ax.errorbar(v, value, xerr=v_se, yerr=se, fmt=marker, color=colour, ms=4, capsize=2,
                label=f"rides: weave, {'real' if part == 're' else 'imaginary'} part")

ax.axhline(0.0, color="k", lw=0.6)
ax.set_xlim(speeds[0], speeds[-1])
ax.set_ylim(-10.0, 10.0)
ax.set_xlabel("speed (m/s)")
ax.set_ylabel("eigenvalue (1/s; imaginary part rad/s)")
weave_speed = bike.weave_speed()
capsize_speed = bike.capsize_speed()
ax.set_title(
    f"{bike.name}: weave speed {weave_speed['value']:.2f} ± {weave_speed['se']:.2f} m/s, "
    f"capsize speed {capsize_speed['value']:.2f} ± {capsize_speed['se']:.2f} m/s"
)
handles, labels = ax.get_legend_handles_labels()
unique = dict(zip(labels, handles))
ax.legend(unique.values(), unique.keys(), loc="lower left", fontsize=8)
fig.tight_layout()
fig.savefig(out, dpi=120)
print(f"wrote {out}: {len(rides)} rides against the model")
