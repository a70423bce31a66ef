"""Benchmark of the fuzzy engine against simpful and scikit-fuzzy on the paper's rule base.

    .venv/bin/python bench/bench_fuzzy.py [--rules assets/rules/paper.toml] [--quick]

Prints a table of median times (medians over repeats): our evaluate_one (and its first
stage, the inputs to the firing strengths), our evaluate on one row, our batch per row
(N = 10,000), simpful per call, scikit-fuzzy per call, and the ratios; evaluate per row for small N against its two paths (the dispatch threshold); plus the
largest differences seen between the engines on the same inputs, and a calibration
figure for the machine (a plain Python loop), because absolute times on a shared VM
vary by a factor of two from minute to minute. "CPU time" is this thread's CPU time
(time.thread_time): it leaves out the time the process waits for a core on a loaded
machine (the wall-clock batch figure can then be several times the CPU figure).

simpful and scikit-fuzzy are test extras (pip install -e .[test]).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import math
import statistics
import time
import warnings
from pathlib import Path

import numpy as np

from fuzzynav.controller import fuzzy as fuzzy_module
from fuzzynav.controller import membership as mf
from fuzzynav.controller.fuzzy import FuzzySystem
from fuzzynav.controller.rulebase import read_toml

ROOT = Path(__file__).resolve().parents[1]

TARGET_ONE_US = 30.0
TARGET_ROW_US = 2.0


def _inputs(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    X = np.column_stack(
        [
            rng.uniform(-1.13, 30, n),
            rng.uniform(0, 3, n),
            rng.uniform(-2 * math.pi, 2 * math.pi, n),
            rng.uniform(-math.pi, math.pi, n),
        ]
    )
    X[rng.random(n) < 0.3, 1] = np.nan  # no obstacle sensed
    return X


def _median_per_call(fn, args_list, repeats: int) -> float:
    """Median over `repeats` passes of the mean time per call over args_list (s)."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for a in args_list:
            fn(a)
        times.append((time.perf_counter() - t0) / len(args_list))
    return statistics.median(times)


def _median_single(fn, args_list, pc=time.perf_counter) -> float:
    """Median of individually timed calls (s)."""
    ts = []
    for a in args_list:
        t0 = pc()
        fn(a)
        ts.append(pc() - t0)
    return statistics.median(ts)


def _calibration_ms() -> float:
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        s = 0.0
        for i in range(1_000_000):
            s += i * 0.5
        best = min(best, time.perf_counter() - t0)
    return best * 1e3


def _simpful(system: FuzzySystem):
    import simpful as sf

    def mfun(t):
        p = t.params
        f = {
            "trimf": lambda: sf.Triangular_MF(*p),
            "trapmf": lambda: sf.Trapezoidal_MF(*p),
            "linsmf": lambda: sf.Trapezoidal_MF(p[0], p[1], p[1], p[1]),
            "linzmf": lambda: sf.Trapezoidal_MF(p[0], p[0], p[0], p[1]),
            "gaussmf": lambda: sf.Gaussian_MF(mu=p[1], sigma=p[0]),
        }[t.shape]()
        return lambda x: 0.0 if x != x else f(x)  # NaN = nothing sensed

    with contextlib.redirect_stdout(io.StringIO()):
        S = sf.FuzzySystem(show_banner=False, verbose=False)
        for v in system.inputs + system.outputs:
            S.add_linguistic_variable(
                v.name,
                sf.LinguisticVariable(
                    [sf.FuzzySet(function=mfun(t), term=t.name) for t in v.terms],
                    universe_of_discourse=list(v.range),
                ),
            )
        texts = []
        for r in system.rules:
            cl = [
                f"({v.name} IS {v.terms[i].name})"
                for v, i in zip(system.inputs, r.antecedent)
                if i is not None
            ]
            ant = cl[0] if len(cl) == 1 else f"{cl[0]} AND {cl[1]}"
            for c in cl[2:]:
                ant = f"({ant}) AND {c}"
            for v, k in zip(system.outputs, r.consequent):
                if k is not None:
                    w = f" WEIGHT {r.weight!r}" if r.weight != 1.0 else ""
                    texts.append(f"IF {ant} THEN ({v.name} IS {v.terms[k].name}){w}")
        S.add_rules(texts)

    def run(x):
        with contextlib.redirect_stdout(io.StringIO()):
            for v, xi in zip(system.inputs, x):
                S.set_variable(v.name, float(xi))
            res = S.Mamdani_inference(subdivisions=system.n_points, ignore_warnings=True)
        return np.array([float(res[v.name]) for v in system.outputs])

    return run


def _skfuzzy(system: FuzzySystem):
    import skfuzzy as fuzz
    from skfuzzy import control as ctrl

    shapes = {
        "trimf": lambda u, p: fuzz.trimf(u, list(p)),
        "trapmf": lambda u, p: fuzz.trapmf(u, list(p)),
        "gaussmf": lambda u, p: fuzz.gaussmf(u, p[1], p[0]),
        "linsmf": lambda u, p: mf.linsmf(u, p),
        "linzmf": lambda u, p: mf.linzmf(u, p),
    }
    ants, cons = [], []
    for v in system.inputs:
        a = ctrl.Antecedent(np.linspace(*v.range, 1001), v.name)
        for t in v.terms:
            a[t.name] = shapes[t.shape](a.universe, t.params)
        ants.append(a)
    for v in system.outputs:
        c = ctrl.Consequent(
            np.linspace(*v.range, system.n_points), v.name, defuzzify_method="centroid"
        )
        for t in v.terms:
            c[t.name] = shapes[t.shape](c.universe, t.params)
        cons.append(c)
    rules = []
    for r in system.rules:
        terms = [
            a[v.terms[i].name]
            for a, v, i in zip(ants, system.inputs, r.antecedent)
            if i is not None
        ]
        ant = terms[0]
        for t in terms[1:]:
            ant = ant & t
        rules.append(
            ctrl.Rule(
                ant,
                tuple(
                    c[v.terms[k].name]
                    for c, v, k in zip(cons, system.outputs, r.consequent)
                    if k is not None
                ),
            )
        )
    # cache=False: scikit-fuzzy otherwise memoises the outputs of inputs it has seen,
    # and the repeats below reuse the same inputs
    sim = ctrl.ControlSystemSimulation(ctrl.ControlSystem(rules), cache=False)

    def run(x):
        for v, xi in zip(system.inputs, x):
            sim.input[v.name] = xi
        sim.compute()
        return np.array([sim.output[v.name] for v in system.outputs])

    return run


def _dispatch_table(system: FuzzySystem, reps: int):
    """evaluate(X) per row against the batch path alone and evaluate_one row by row, for
    small N around the dispatch threshold (CPU time, medians)."""
    from rich.table import Table

    def per_row(fn, X, n_calls):
        samples = []
        for _ in range(reps):
            c0 = time.thread_time()
            for _ in range(n_calls):
                fn(X)
            samples.append((time.thread_time() - c0) / n_calls / len(X))
        return statistics.median(samples)

    def batch_only(X):
        saved = fuzzy_module._ROW_BY_ROW_MAX
        fuzzy_module._ROW_BY_ROW_MAX = 0
        try:
            return system.evaluate(X)
        finally:
            fuzzy_module._ROW_BY_ROW_MAX = saved

    def one_by_one(X):
        return [system.evaluate_one(x) for x in X]

    threshold = fuzzy_module._ROW_BY_ROW_MAX
    t = Table(
        title=f"evaluate(X) per row by batch size N (CPU us, medians of {reps}); rows up to "
        f"N = {threshold} go one by one"
    )
    for col in ("N", "evaluate (dispatched)", "batch path alone", "evaluate_one per row", "best"):
        t.add_column(col, justify="right")
    worst = 0.0
    for n in (1, 2, 4, 8, 12, 16, 17, 24, 32, 64, 256, 4096):
        X = _inputs(n, seed=n)
        calls = max(3, 4000 // n)
        d = per_row(system.evaluate, X, calls)
        b = per_row(batch_only, X, calls)
        o = per_row(one_by_one, X, calls)
        worst = max(worst, d / min(b, o))
        t.add_row(
            str(n),
            f"{d * 1e6:.1f}",
            f"{b * 1e6:.1f}",
            f"{o * 1e6:.1f}",
            "batch" if b < o else "one by one",
        )
    return t, worst


def _verdict(target: float, wall: float, cpu: float) -> str:
    def mark(v):
        return "[green]met[/]" if v <= target else "[red]missed[/]"

    return f"<= {target:g} us: wall {mark(wall)}, CPU {mark(cpu)}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rules", default=str(ROOT / "assets" / "rules" / "paper.toml"))
    ap.add_argument("--quick", action="store_true", help="fewer repeats")
    args = ap.parse_args(argv)
    from rich.console import Console
    from rich.table import Table

    console = Console(width=130)
    system = read_toml(args.rules)
    n_batch = 10_000
    X = _inputs(n_batch)
    xs = [list(map(float, x)) for x in X[:2000]]
    reps = 3 if args.quick else 7

    # warm-up
    system.evaluate(X)
    for x in xs[:200]:
        system.evaluate_one(x)

    one_s = statistics.median(_median_single(system.evaluate_one, xs) for _ in range(reps))
    one_cpu = statistics.median(
        _median_single(system.evaluate_one, xs, time.thread_time) for _ in range(reps)
    )
    one_arr_s = statistics.median(
        _median_single(system.evaluate_one, list(X[:2000])) for _ in range(reps)
    )
    front_s = statistics.median(_median_single(system._strengths_one, xs) for _ in range(reps))
    batch_times, batch_cpu = [], []
    for _ in range(reps * 2):
        t0, c0 = time.perf_counter(), time.thread_time()
        system.evaluate(X)
        batch_times.append(time.perf_counter() - t0)
        batch_cpu.append(time.thread_time() - c0)
    row_s = statistics.median(batch_times) / n_batch
    row_cpu = statistics.median(batch_cpu) / n_batch

    simp = _simpful(system)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        skf = _skfuzzy(system)
        # inputs skfuzzy can take: in range, no NaN, something fires
        Xs = _inputs(60, seed=1)
        Xs[:, 1] = np.nan_to_num(Xs[:, 1], nan=2.9)
        simp_s = _median_per_call(simp, list(Xs[:20]), 3 if args.quick else 5)
        skf_s = _median_per_call(skf, list(Xs[:20]), 3 if args.quick else 5)
        d_simp = max(np.abs(simp(x) - system.evaluate_one(x)).max() for x in Xs[:40])
        d_skf = max(np.abs(skf(x) - system.evaluate_one(x)).max() for x in Xs[:40])
    one_row = [X[i : i + 1] for i in range(2000)]
    eval1_s = statistics.median(_median_single(system.evaluate, one_row) for _ in range(reps))
    ident = np.array_equal(
        np.array([system.evaluate_one(x) for x in X[:3000]]), system.evaluate(X)[:3000]
    )

    us = 1e6
    t = Table(
        title=f"Fuzzy engine on {Path(args.rules).name}: {len(system.inputs)} inputs, "
        f"{len(system.outputs)} outputs, {len(system.rules)} rules, {system.n_points}-point grid "
        f"(medians of {reps} repeats)"
    )
    t.add_column("what")
    t.add_column("median time", justify="right")
    t.add_column("CPU time", justify="right")
    t.add_column("vs our evaluate_one", justify="right")
    t.add_column("target", justify="right")
    t.add_row(
        "ours: evaluate_one (list input)",
        f"{one_s * us:.1f} us",
        f"{one_cpu * us:.1f} us",
        "1",
        _verdict(TARGET_ONE_US, one_s * us, one_cpu * us),
    )
    t.add_row(
        "ours: evaluate_one (ndarray input)",
        f"{one_arr_s * us:.1f} us",
        "",
        f"{one_arr_s / one_s:.2f}",
        "",
    )
    t.add_row(
        "  its first stage (memberships to firing strengths)",
        f"{front_s * us:.1f} us",
        "",
        f"{front_s / one_s:.2f}",
        "",
    )
    t.add_row(
        "ours: evaluate on one row (N=1)",
        f"{eval1_s * us:.1f} us",
        "",
        f"{eval1_s / one_s:.2f}",
        "",
    )
    t.add_row(
        f"ours: evaluate, per row (N={n_batch:,})",
        f"{row_s * us:.2f} us",
        f"{row_cpu * us:.2f} us",
        f"1/{one_s / row_s:.1f}",
        _verdict(TARGET_ROW_US, row_s * us, row_cpu * us),
    )
    t.add_row("simpful 2.12, per call", f"{simp_s * 1e3:.1f} ms", "", f"x{simp_s / one_s:,.0f}", "")
    t.add_row(
        "scikit-fuzzy 0.5, per call", f"{skf_s * 1e3:.1f} ms", "", f"x{skf_s / one_s:,.0f}", ""
    )
    console.print(t)
    console.print(
        f"batch row vs simpful call: x{simp_s / row_s:,.0f}; vs scikit-fuzzy: x{skf_s / row_s:,.0f}"
    )
    console.print(
        f"largest |ours - simpful| on 40 inputs: {d_simp:.2e} V (same grid; exact oracle)"
    )
    console.print(
        f"largest |ours - scikit-fuzzy| on 40 inputs: {d_skf:.2e} V (area centroid, see tests)"
    )
    console.print(f"evaluate_one == evaluate bit for bit on 3000 rows: {ident}")
    table, worst = _dispatch_table(system, reps)
    console.print(table)
    console.print(
        f"dispatched evaluate vs the better of the two paths, worst N: x{worst:.2f} "
        "(1.00 = the dispatch always picks the faster path)"
    )
    console.print(
        f"machine calibration: a 1e6-iteration Python float loop takes {_calibration_ms():.0f} ms "
        "(a typical desktop: ~40-60 ms)"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
