"""bikeproc in Python against the command line: every call gives the numbers `bikeproc … --json`
gives, to the last digit (both are the same Rust core; the JSON is read back exactly)."""

import csv
import json
import pathlib
import shutil
import subprocess
import time

import numpy as np
import pytest

import bikeproc

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT / "data"
SHARED = ROOT.parent / "shared" / "reference"


@pytest.fixture(scope="session")
def cli():
    """The command line built from the same checkout (`cargo build --release`)."""
    exe = ROOT / "target" / "release" / "bikeproc"
    if not exe.exists():
        subprocess.run(["cargo", "build", "--release", "--quiet"], cwd=ROOT, check=True)

    def run(*args):
        out = subprocess.run(
            [str(exe), *map(str, args), "--json"],
            cwd=ROOT,
            check=True,
            capture_output=True,
            text=True,
        )
        return json.loads(out.stdout)

    return run


def test_period_of_a_log_is_the_commands(cli):
    log = DATA / "frame_torsion" / "frame_torsion_1a.log"
    assert bikeproc.period(log) == cli("period", log)


def test_period_of_the_shared_signals_is_the_commands(cli):
    for name in ["browserins_fork_compound_first1_1000hz.csv", "resonance_wheel_radial_torsional_100hz.csv"]:
        assert bikeproc.period(SHARED / "signals" / name) == cli("period", SHARED / "signals" / name)


def test_fit_period_on_arrays_is_the_commands_on_the_file(cli):
    path = SHARED / "signals" / "resonance_wheel_axial_compound_500hz.csv"
    with open(path) as f:
        rows = list(csv.reader(f))[1:]
    t = np.array([float(r[0]) for r in rows])
    x = np.array([float(r[1]) for r in rows])
    ours = bikeproc.fit_period(t, x)
    theirs = cli("period", path)
    # The arrays have no column name: everything else is the same to the bit.
    assert {k: v for k, v in ours.items() if k != "signal"} == {
        k: v for k, v in theirs.items() if k != "signal"
    }
    # A published reference (the shared README's 1.4291 s for this wheel, to 4 digits).
    assert abs(ours["period_s"] - 1.4291) < 5e-4


def test_read_log_gives_the_grid_and_channels():
    log = bikeproc.read_log(DATA / "frame_torsion" / "frame_torsion_1a.log")
    assert log["sample_rate_hz"] == 100.0
    n = len(log["time_s"])
    assert n > 1000 and all(len(v) == n for v in log["channels"].values())
    # Times are the grid positions at 100 Hz; the holes are the missing samples counted.
    np.testing.assert_array_equal(log["time_s"], log["grid_index"] * 0.01)
    assert log["grid_index"][-1] + 1 - n == log["gaps"]["missing_samples"]
    assert log["sensors"] and set(log["sensors"][0]["columns"]) <= set(log["channels"])


def test_calibrate_bar_and_inertia_are_the_commands(cli, tmp_path):
    # The command writes calibration.toml into the folder: run it on a copy (with the empty
    # fixture's folder it refers to).
    for folder in ["bar_calibration", "empty_fixture"]:
        shutil.copytree(DATA / folder, tmp_path / folder)
    bar = tmp_path / "bar_calibration"
    assert bikeproc.calibrate_bar(DATA / "bar_calibration") == cli("calibrate-bar", bar)
    for folder in ["frame_torsion", "handlebar_torsion", "frame_compound", "rear_wheel_compound"]:
        assert bikeproc.inertia(DATA / folder) == cli("inertia", DATA / folder)


@pytest.mark.parametrize(
    "bike",
    [
        DATA / "lab_bike.toml",
        SHARED / "bicycleparameters" / "BenchmarkBenchmark.txt",
        SHARED / "bicycleparameters" / "RigidMeasured.txt",
    ],
)
def test_bicycle_stability_is_the_commands(cli, bike):
    b = bikeproc.Bicycle.from_file(bike)
    report = cli("stability", "--bike", bike, "--speeds", "0:10:0.5")
    assert b.stability(0.0, 10.0, 0.5) == report
    assert b.stable_range() == [
        {"low_mps": lo, "high_mps": hi} for lo, hi in report["stable_ranges_mps"]
    ]
    # The same as arrays: every eigenvalue and standard error of the command's rows.
    table = b.stability_table(0.0, 10.0, 0.5)
    rows = report["eigenvalues"]
    assert table["speeds_mps"].tolist() == [r["speed_mps"] for r in rows]
    assert table["eigenvalues"].shape == (len(rows), 4)
    named = dict(zip(table["modes"], range(4)))
    for i, r in enumerate(rows):
        got = sorted(table["eigenvalues"][i].tolist(), key=lambda z: (-z.real, -z.imag))
        assert got == [complex(e["re"], e["im"]) for e in r["all"]]
        weave = named["Weave"]
        assert table["eigenvalues"][i, weave] == complex(r["weave"]["re"], r["weave"]["im"])
        assert table["re_se"][i, weave] == r["weave"]["re_se"]
        assert table["im_se"][i, named["Capsize"]] == r["capsize"]["im_se"]
    assert table["weave_speed_mps"] == report["weave_speed_mps"]
    assert [list(x) for x in table["stable_ranges_mps"]] == [list(x) for x in report["stable_ranges_mps"]]
    assert b.weave_speed() == {"value": report["weave_speed_mps"], "se": report["weave_speed_se_mps"]}
    assert b.capsize_speed() == {
        "value": report["capsize_speed_mps"],
        "se": report["capsize_speed_se_mps"],
    }


def test_eigenvalues_against_meijaard_2007():
    # Meijaard et al. (2007), Table 2: the benchmark bicycle's weave and capsize speeds.
    b = bikeproc.Bicycle.from_file(SHARED / "bicycleparameters" / "BenchmarkBenchmark.txt")
    assert abs(b.weave_speed()["value"] - 4.292382) < 1e-5
    assert abs(b.capsize_speed()["value"] - 6.024262) < 1e-5
    # Table 2 at v = 5 m/s: weave −0.77534188219585 ± 4.46486771378823i, capsize
    # −0.32286642900409, castor −14.07838969279822.
    ev = b.eigenvalues(np.array([5.0]))[0]
    assert ev.shape == (4,) and ev.dtype == np.complex128
    assert abs(ev[0] - complex(-0.77534188219585, 4.46486771378823)) < 1e-9
    assert abs(ev[2] - -0.32286642900409) < 1e-9
    assert abs(ev[3] - -14.07838969279822) < 1e-9


def test_eigenvalues_over_100001_speeds_well_under_a_second():
    b = bikeproc.Bicycle.from_file(DATA / "lab_bike.toml")
    speeds = np.linspace(0.0, 10.0, 100_001)
    start = time.perf_counter()
    ev = b.eigenvalues(speeds)
    elapsed = time.perf_counter() - start
    assert ev.shape == (100_001, 4)
    assert np.all(np.isfinite(ev))
    assert elapsed < 0.5, f"{elapsed:.3f} s"


def test_dynamic_and_gap_are_the_commands(cli):
    ride = DATA / "ride_03.log"
    assert bikeproc.dynamic(ride, speed=3.9) == cli("dynamic", ride, "--speed", 3.9)
    campaign = bikeproc.dynamic(DATA / "rides.toml")
    assert campaign == cli("dynamic", DATA / "rides.toml")
    assert len(campaign["rides"]) == 16
    assert bikeproc.gap(DATA / "rides.toml") == cli("gap", DATA / "rides.toml")


def test_a_bad_file_raises_with_its_file_and_line():
    bad = ROOT / "fixtures" / "bad" / "bad_number.log"
    with pytest.raises(bikeproc.BikeprocError) as e:
        bikeproc.read_log(bad)
    assert "fixtures/bad/bad_number.log:10:16" in str(e.value)
    with pytest.raises(bikeproc.BikeprocError, match=r"bad_number.log:10:16"):
        bikeproc.period(bad)
    with pytest.raises(bikeproc.BikeprocError, match=r"sample 3: time"):
        bikeproc.fit_period(np.arange(10.0) * np.array([1, 1, 1, 0, 1, 1, 1, 1, 1, 1]), np.zeros(10))
    with pytest.raises(bikeproc.BikeprocError, match="START:END:STEP"):
        bikeproc.Bicycle.from_file(DATA / "lab_bike.toml").stability(5.0, 1.0, 0.1)


@pytest.mark.parametrize("speed", [-1.0, 0.0, float("nan"), 1e9])
def test_dynamic_refuses_a_speed_that_is_no_riding_speed(speed):
    # Issue 33: speed=-1.0 returned speed_mps -1.20.
    with pytest.raises(bikeproc.BikeprocError, match="speed: .* is not a riding speed"):
        bikeproc.dynamic(DATA / "ride_03.log", speed=speed)


def test_eigenvalues_refuse_a_speed_that_is_not_finite():
    bike = bikeproc.Bicycle.from_file(DATA / "lab_bike.toml")
    with pytest.raises(bikeproc.BikeprocError, match=r"speeds\[1\] = NaN: expected finite speeds"):
        bike.eigenvalues(np.array([1.0, float("nan")]))


RIGID = SHARED / "bicycleparameters" / "RigidBenchmark.txt"
JASON = SHARED / "bicycleparameters" / "JasonRigidBenchmark.txt"


def test_sensitivity_with_a_rider_is_the_commands(cli):
    b = bikeproc.Bicycle.from_file(RIGID).with_rider(JASON)
    assert b.sensitivity([5.0, 7.0]) == cli(
        "sensitivity", "--bike", RIGID, "--rider", JASON, "--speeds", "5,7"
    )
    lab = bikeproc.Bicycle.from_file(DATA / "lab_bike.toml")
    assert lab.sensitivity() == cli("sensitivity", "--bike", DATA / "lab_bike.toml")


def test_compare_and_design_are_the_commands(cli, tmp_path):
    bench = SHARED / "bicycleparameters" / "BenchmarkBenchmark.txt"
    bikes = [bikeproc.Bicycle.from_file(p) for p in (bench, DATA / "lab_bike.toml", RIGID)]
    assert bikeproc.compare(bikes) == cli("compare", bench, DATA / "lab_bike.toml", RIGID)
    lab = bikeproc.Bicycle.from_file(DATA / "lab_bike.toml")
    out = tmp_path / "designed.txt"
    got = lab.design((2.9, 5.2), ["trail", "head_angle"], out=out)
    want = cli(
        "design", "--bike", DATA / "lab_bike.toml", "--stable", "2.9:5.2",
        "--vary", "trail,head_angle",
    )
    assert got == want and got["reached"]
    assert cli("stability", "--bike", out, "--speeds", "0:10:1")["weave_speed_mps"] <= 2.9 + 1e-5
    with pytest.raises(bikeproc.BikeprocError, match="not a design variable"):
        lab.design((2.9, 5.2), ["fork"])
