"""BicycleParameters' period fit (bicycleparameters.period.get_period) timed on the six shared
pendulum signals, its plotting stubbed out, for the side-by-side with bikeproc's
`period_fit_reference` benchmark (benches/core.rs).

    python3 -m venv /tmp/bpenv && /tmp/bpenv/bin/pip install bicycleparameters
    /tmp/bpenv/bin/python benches/kernels/bicycleparameters_period.py
"""
import csv, pathlib, time
import numpy as np
import bicycleparameters.period as period

class Dummy:
    def __getattr__(self, name):
        return lambda *a, **k: (Dummy(), Dummy()) if name == 'subplots' else Dummy()
    def __call__(self, *a, **k):
        return Dummy()
period.plt = Dummy()
period.plot_osfit = lambda *a, **k: None

d = str(pathlib.Path(__file__).resolve().parents[3] / 'shared/reference/signals') + '/'
for name in ['browserins_fork_compound_first1_1000hz.csv', 'browserins_fork_compound_first1_100hz.csv',
             'resonance_wheel_radial_torsional_500hz.csv', 'resonance_wheel_radial_torsional_100hz.csv',
             'resonance_wheel_axial_compound_500hz.csv', 'resonance_wheel_axial_compound_100hz.csv']:
    rows = list(csv.reader(open(d + name)))[1:]
    t = np.array([float(a) for a, b in rows]); x = np.array([float(b) for a, b in rows])
    rate = (len(t) - 1) / (t[-1] - t[0])
    out = None
    n = 30 if len(t) > 10000 else 100
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        try:
            out = period.get_period(x, int(round(rate)), None)
        except Exception as e:
            out = repr(e)
        times.append(time.perf_counter() - t0)
    print(f"{name}: median {1e3*np.median(times):.2f} ms, period {out}")
