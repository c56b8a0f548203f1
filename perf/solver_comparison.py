#!/usr/bin/env python3
"""Ours and Ceres on the same problems in one run (issue 4).

For every problem it runs, one after the other on the same machine:
  ours/cholmod          graphslam solve FILE --initialization odometry --solver cholmod
  ours/pcg              graphslam solve FILE --initialization odometry --solver pcg
                                         --preconditioner subgraph
  ours/auto             graphslam solve FILE --initialization odometry  (--solver auto)
  ceres/sparse_schur    graphslam_ceres_peer FILE --linear-solver sparse_schur
  ceres/iterative_schur graphslam_ceres_peer FILE --linear-solver iterative_schur
                        (Ceres' defaults: eta 0.1, <= 500 CG iterations)
  ceres/iterative_schur_tight  ... --eta 1e-4 --max-linear-iterations 5000
                        (the setting that reaches the optimum, docs/peers.md)
all with at most 200 Levenberg-Marquardt iterations, from the same odometry
guess (paper Table 1), every report written with --report.

--start progressive|pose-graph gives every run the same, better start instead
(from odometry, large landmark problems leave every solver in a different
local minimum or far from any within the iteration cap): graphslam runs that
initializer once (`graphslam solve FILE --initialization START
--max-iterations 0 -o OUT/NAME_start_START.g2o`, row "start/START"), and every
run then reads that file: ours with `--initialization as-given` (the guess
unchanged), Ceres with its usual Table 1 initialization, which keeps every
vertex the file gives. Ceres runs write --iteration-log, so a run stopped by
the timeout still gives its iterations, time per iteration and last chi2.
It writes
OUT/solver_comparison.csv (one row per run) and OUT/solver_comparison.md (the
table of docs/benchmarks.md): ms per iteration (mean of per_iteration[].seconds),
total seconds (the report's `seconds`: read to report), CPU seconds of the
whole process (user + system; the fairer figure on a loaded machine), final
chi2, peak RSS,
and the ratios of ours/pcg to Ceres ITERATIVE_SCHUR: time per iteration, and
final chi2 (the target: <= 0.5 at the same chi2 within 0.1 %).

  perf/solver_comparison.py --bin build/bin --out /tmp/cmp \
      [--problems intel,M3500,city10000,victoria,sim1e5,sim1e5obs] [--skip RUN,...] [--threads N]
      [--timeout S] [--max-iterations N] [--pcg-eta-max E] [--pcg-eta-min E] [--pcg-deflation M]
      [--pcg-truncation F]
      [--start odometry|progressive|pose-graph]

Simulated problems (sim1e4, sim1e5, sim1e6, sim1e5obs, sim1e6obs) are generated
once into OUT with `graphslam simulate -o DIR --poses N --features M --format g2o
--gps-every 25 --alpha 1e-4 1e-5 3e-7 1e-4 3e-7 1e-4` (sim1e5obs, sim1e6obs add
`--landmark-spacing 0.05 0.08 --sensor-range 6.5`; see SIMULATED); the
simulator's summary (features observed, observations) goes to DIR/simulate.txt
and is printed.

sim1e7obs (1.5*10^6 poses, 10^7 features, ~8*10^7 observations: too large for
a g2o file in memory) is a chunk store instead: `graphslam simulate
--streaming --compress` with the options of sim1e6obs into OUT/sim1e7obs/sim
(same distribution, a different file than the in-memory simulator), `graphslam
ingest` into OUT/sim1e7obs/store (~4 GB of disk in all), and every run solves
the store (streaming mode) with its own `--checkpoint OUT/...checkpoint.json`.
It has no start file: with --start pose-graph each of ours runs `--initialization
pose-graph` itself (the pose-only solve uses that run's linear solver, so the
starts agree to the pose-only solve's tolerance, not bit for bit); the Ceres
runs are skipped (the peer reads g2o). Recommended, ours only (the runs go one
after the other: peak RSS ~12 GiB with CHOLMOD, ~4.6 GiB with PCG; ~150 / ~110
CPU s per LM iteration, docs/history/benchmarks-notebook-2026-11.md "Problems that observe 10^7
features"):

  nice -n 10 perf/solver_comparison.py --bin build/bin --out /work/scale/e7obs/cmp \
      --problems sim1e7obs --start pose-graph --skip ours/auto --threads 1 \
      --max-iterations 3 --timeout 14400
"""
import argparse
import csv
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

DATASETS = "/work/shared/datasets"
PROBLEMS = {
    "intel": f"{DATASETS}/freiburg_course_g2o/intel.g2o",
    "M3500": f"{DATASETS}/freiburg_course_g2o/input_M3500_g2o.g2o",
    "city10000": f"{DATASETS}/sesync_posegraphs/city10000.g2o",
    "victoria": f"{DATASETS}/victoria_park/victoriaPark-full.g2o",
}
# name -> (poses, features) for `graphslam simulate`, with a GPS fix every 25
# poses and 100x less control noise than the default (SIMULATE_NOISE): with
# the default noise the odometry guess of a 10^4-pose campus is so far off
# that neither our LM nor Ceres' reaches the optimum in 200 iterations.
# sim1e5 and sim1e6 observe only part of their nominal features (the robot
# passes few of the 6-10 m spaced landmarks of a large campus: sim1e6 observes
# ~42 k of 10^6). sim1e5obs and sim1e6obs instead observe ~97 % and ~93 % of
# theirs, ~8 times each: a dense landmark field (5-8 cm apart) on a campus
# small enough for the drive to cover, seen from at most 6.5 m (landmarks
# stand 6 m beside the street centre, so each is seen over ~5 m of a pass).
# name -> (poses, features[, extra `graphslam simulate` options])
DENSE = ["--landmark-spacing", "0.05", "0.08", "--sensor-range", "6.5"]
SIMULATED = {"sim1e4": (10000, 10000), "sim1e5": (20000, 100000),
             "sim1e6": (200000, 1000000), "sim1e5obs": (15000, 100000, DENSE),
             "sim1e6obs": (150000, 1000000, DENSE)}
# name -> (poses, features, extra options) simulated with --streaming and
# solved from a chunk store (see the docstring).
STORES = {"sim1e7obs": (1500000, 10000000, DENSE)}
SIMULATE_NOISE = ["--gps-every", "25", "--alpha", "0.0001", "0.00001", "0.0000003", "0.0001",
                  "0.0000003", "0.0001"]

RUNS = ["ours/cholmod", "ours/pcg", "ours/auto", "ceres/sparse_schur",
        "ceres/iterative_schur", "ceres/iterative_schur_tight"]


def write_atomically(path, text):
    directory = os.path.dirname(os.path.abspath(path))
    fd, temp = tempfile.mkstemp(dir=directory, prefix=".tmp_")
    with os.fdopen(fd, "w") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(temp, path)


def command(run, binaries, path, report, threads, max_iterations=200, pcg_eta_max=None,
            initialization="odometry", iteration_log=None, pcg_eta_min=None, pcg_deflation=None,
            pcg_truncation=None):
    ours = [f"{binaries}/graphslam", "solve", path, "--initialization", initialization,
            "--max-iterations", str(max_iterations), "--threads", str(threads), "--report",
            report, "-q"]
    eta = [] if pcg_eta_max is None else ["--pcg-eta-max", str(pcg_eta_max)]
    eta += [] if pcg_eta_min is None else ["--pcg-eta-min", str(pcg_eta_min)]
    eta += [] if pcg_deflation is None else ["--pcg-deflation", str(pcg_deflation)]
    eta += [] if pcg_truncation is None else ["--pcg-truncation", str(pcg_truncation)]
    ceres = [f"{binaries}/graphslam_ceres_peer", path, "--threads", str(threads),
             "--max-iterations", str(max_iterations), "--report", report, "-q"]
    if iteration_log:
        ceres += ["--iteration-log", iteration_log]
    return {
        "ours/cholmod": ours + ["--solver", "cholmod"],
        "ours/pcg": ours + ["--solver", "pcg", "--preconditioner", "subgraph"] + eta,
        "ours/auto": ours + eta,
        "ceres/sparse_schur": ceres + ["--linear-solver", "sparse_schur"],
        "ceres/iterative_schur": ceres + ["--linear-solver", "iterative_schur"],
        "ceres/iterative_schur_tight": ceres + ["--linear-solver", "iterative_schur", "--eta",
                                                "1e-4", "--max-linear-iterations", "5000"],
    }[run]


def problem_path(name, binaries, out):
    if name in PROBLEMS:
        return PROBLEMS[name]
    if name in STORES:
        return store_path(name, binaries, out)
    poses, features, *extra = SIMULATED[name]
    folder = os.path.join(out, name)
    graph = os.path.join(folder, "graph.g2o")
    summary = os.path.join(folder, "simulate.txt")
    if not os.path.exists(graph):
        # The simulator's summary says how many features are actually observed
        # and how many observations there are: kept next to the graph.
        done = subprocess.run([f"{binaries}/graphslam", "simulate", "-o", folder, "--poses",
                               str(poses), "--features", str(features), "--format", "g2o"]
                              + SIMULATE_NOISE + (extra[0] if extra else []),
                              check=True, capture_output=True, text=True)
        write_atomically(summary, done.stdout + done.stderr)
    if os.path.exists(summary):
        with open(summary) as f:
            print(f"{name}: {f.read().strip()}", flush=True)
    return graph


def store_path(name, binaries, out):
    """Simulates (streaming) and ingests the store problem `name` once; returns the store."""
    poses, features, extra = STORES[name]
    folder = os.path.join(out, name)
    store = os.path.join(folder, "store")
    summary = os.path.join(folder, "simulate.txt")
    done_marker = os.path.join(folder, "ingested")
    if not os.path.exists(done_marker):
        sim = os.path.join(folder, "sim")
        simulated = subprocess.run([f"{binaries}/graphslam", "simulate", "--streaming", "--compress",
                                    "-o", sim, "--poses", str(poses), "--features", str(features)]
                                   + SIMULATE_NOISE + extra, check=True, capture_output=True,
                                   text=True)
        write_atomically(summary, simulated.stdout + simulated.stderr)
        subprocess.run([f"{binaries}/graphslam", "ingest", os.path.join(sim, "log.graphslam.zst"),
                        "-o", store, "-q"], check=True)
        write_atomically(done_marker, "")
    if os.path.exists(summary):
        with open(summary) as f:
            print(f"{name}: {f.read().strip()}", flush=True)
    return store


def start_path(name, path, start, binaries, out, threads, timeout):
    """Writes the initialized guess of `path` once; returns (file, row of its run)."""
    graph = os.path.join(out, f"{name}_start_{start}.g2o")
    report = os.path.join(out, f"{name}_start_{start}.json")
    cmd = [f"{binaries}/graphslam", "solve", path, "--initialization", start, "--max-iterations",
           "0", "--threads", str(threads), "-o", graph, "--report", report, "-q"]
    row = {"problem": name, "run": f"start/{start}", "command": " ".join(cmd)}
    if not os.path.exists(graph):
        exit_code, wall, cpu = timed_run(cmd, timeout)
        row.update({"exit": exit_code, "wall_s": round(wall, 3), "cpu_s": round(cpu, 3)})
        # --max-iterations 0 is "not converged" (exit 4) by definition.
        if exit_code not in (0, 4) or not os.path.exists(graph):
            raise SystemExit(f"{name}: writing the {start} start failed ({exit_code})")
    if os.path.exists(report):
        with open(report) as f:
            r = json.load(f)
        row.update({"iterations": 0, "termination": "initial guess", "final_chi2": r["final_chi2"],
                    "total_s": r.get("seconds"), "peak_rss_mib": r.get("peak_rss_bytes", 0) / 2**20})
        row.setdefault("cpu_s", round(r.get("cpu_seconds", 0.0), 3))
    return graph, row


def timed_run(cmd, timeout):
    """Runs cmd; returns (exit code or "timeout", wall s, CPU s of the child)."""
    start = time.monotonic()
    # CPU seconds of the child (user + system, whole process: reading the
    # input included): on a shared, loaded machine the fairer figure than
    # wall-clock time, which counts the waits for a core.
    children_before = resource.getrusage(resource.RUSAGE_CHILDREN)
    try:
        result = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                text=True, timeout=timeout)
        exit_code = result.returncode
    except subprocess.TimeoutExpired:
        exit_code = "timeout"
    wall = time.monotonic() - start
    children_after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (children_after.ru_utime - children_before.ru_utime +
           children_after.ru_stime - children_before.ru_stime)
    return exit_code, wall, cpu


def from_iteration_log(path):
    """The figures of a Ceres run stopped before its report, from --iteration-log."""
    if not path or not os.path.exists(path):
        return {}
    with open(path) as f:
        per = [json.loads(line) for line in f if line.strip().endswith("}")]
    if not per:
        return {}
    figures = {
        "iterations": len(per),
        "termination": f"timeout after {len(per)} iterations",
        "ms_per_iteration": 1e3 * sum(i["seconds"] for i in per) / len(per),
        "linear_iterations": sum(i.get("linear_solver_iterations", 0) for i in per),
        "final_chi2": min(i["chi2"] for i in per),  # accepted iterates only lower it
    }
    # CPU per iteration from the differences (the first entry includes reading).
    if len(per) >= 2:
        figures["cpu_ms_per_iteration"] = (
            1e3 * (per[-1]["cpu_seconds"] - per[0]["cpu_seconds"]) / (len(per) - 1))
    return figures


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bin", default="build/bin")
    parser.add_argument("--out", required=True)
    parser.add_argument("--problems", default="intel,M3500,city10000,victoria,sim1e5")
    parser.add_argument("--skip", default="", help="runs to leave out, e.g. ceres/iterative_schur_tight")
    parser.add_argument("--threads", type=int, default=1,
                        help="threads for both (1: least exposed to other load; 0: all cores)")
    parser.add_argument("--timeout", type=float, default=1200.0, help="seconds per run")
    parser.add_argument("--max-iterations", type=int, default=200,
                        help="Levenberg-Marquardt iteration cap of every run (large problems)")
    parser.add_argument("--pcg-eta-max", type=float, default=None,
                        help="ours/pcg and ours/auto: --pcg-eta-max (default: graphslam's)")
    parser.add_argument("--pcg-eta-min", type=float, default=None,
                        help="ours/pcg and ours/auto: --pcg-eta-min (default: graphslam's)")
    parser.add_argument("--pcg-deflation", type=int, default=None,
                        help="ours/pcg and ours/auto: --pcg-deflation (default: graphslam's)")
    parser.add_argument("--pcg-truncation", type=float, default=None,
                        help="ours/pcg and ours/auto: --pcg-truncation (default: graphslam's)")
    parser.add_argument("--start", default="odometry",
                        choices=["odometry", "progressive", "pose-graph"],
                        help="the start of every run: the input's odometry guess, or the "
                             "initializer's guess written once and given to all")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    skip = set(filter(None, args.skip.split(",")))
    rows = []
    for name in args.problems.split(","):
        path = problem_path(name, args.bin, args.out)
        initialization = "odometry"
        if name in STORES:
            # No start file for a store: every run initializes itself.
            initialization = args.start
        elif args.start != "odometry":
            path, row = start_path(name, path, args.start, args.bin, args.out, args.threads,
                                   args.timeout)
            initialization = "as-given"
            rows.append(row)
            print(json.dumps({k: v for k, v in row.items() if k != "command"}), flush=True)
        for run in RUNS:
            if run in skip or (name in STORES and run.startswith("ceres/")):
                continue
            report = os.path.join(args.out, f"{name}_{run.replace('/', '_')}.json")
            iteration_log = (report[:-len(".json")] + ".iterations.jsonl"
                             if run.startswith("ceres/") else None)
            cmd = command(run, args.bin, path, report, args.threads, args.max_iterations,
                          args.pcg_eta_max, initialization, iteration_log, args.pcg_eta_min,
                          args.pcg_deflation, args.pcg_truncation)
            if name in STORES:  # not STORE/checkpoint.json: each run its own
                cmd += ["--checkpoint", report[:-len(".json")] + ".checkpoint.json"]
            exit_code, wall, cpu = timed_run(cmd, args.timeout)
            row = {"problem": name, "run": run, "exit": exit_code, "wall_s": round(wall, 3),
                   "cpu_s": round(cpu, 3), "command": " ".join(cmd)}
            if exit_code in (0, 4) and os.path.exists(report):
                with open(report) as f:
                    r = json.load(f)
                per = r.get("per_iteration", [])
                row.update({
                    "solver": r.get("solver"),
                    "iterations": r.get("iterations"),
                    "termination": r.get("termination"),
                    "ms_per_iteration": 1e3 * sum(i["seconds"] for i in per) / max(1, len(per)),
                    "linear_iterations": sum(i.get("linear_solver_iterations", 0) for i in per),
                    "total_s": r.get("seconds"),
                    "final_chi2": r.get("final_chi2"),
                    "peak_rss_mib": r.get("peak_rss_bytes", 0) / 2**20,
                })
                if "optimize_cpu_seconds" in r:
                    row["cpu_ms_per_iteration"] = (1e3 * r["optimize_cpu_seconds"] /
                                                   max(1, r.get("iterations") or 1))
            elif exit_code == "timeout":
                row.update(from_iteration_log(iteration_log))
                if "iterations" in row:
                    row["solver"] = run.split("/")[1].replace("_tight", "").upper()
            rows.append(row)
            print(json.dumps({k: v for k, v in row.items() if k != "command"}), flush=True)
            write_outputs(rows, args.out)
    return 0


def write_outputs(rows, out):
    fields = ["problem", "run", "solver", "exit", "iterations", "termination", "ms_per_iteration",
              "cpu_ms_per_iteration", "linear_iterations", "total_s", "final_chi2",
              "peak_rss_mib", "ms_ratio_vs_ceres_iterative", "cpu_ms_ratio_vs_ceres_iterative",
              "chi2_ratio_vs_ceres_iterative", "cpu_ms_ratio_vs_cholmod", "chi2_ratio_vs_cholmod",
              "wall_s", "cpu_s", "command"]
    # Ratios of every run to Ceres ITERATIVE_SCHUR on the same problem (the
    # tight run if it has figures, a timed-out one included, else the default
    # one) and to ours/cholmod.
    by_problem = {}
    for row in rows:
        by_problem.setdefault(row["problem"], {})[row["run"]] = row
    for row in rows:
        runs = by_problem[row["problem"]]
        peer = runs.get("ceres/iterative_schur_tight")
        if peer is None or "ms_per_iteration" not in peer:
            peer = runs.get("ceres/iterative_schur")
        for prefix, reference in (("", peer), ("cholmod", runs.get("ours/cholmod"))):
            suffix = "vs_cholmod" if prefix else "vs_ceres_iterative"
            if not reference or "ms_per_iteration" not in row:
                continue
            if "ms_per_iteration" in reference and not prefix:
                row[f"ms_ratio_{suffix}"] = row["ms_per_iteration"] / reference["ms_per_iteration"]
            if reference.get("cpu_ms_per_iteration") and row.get("cpu_ms_per_iteration"):
                row[f"cpu_ms_ratio_{suffix}"] = (row["cpu_ms_per_iteration"] /
                                                 reference["cpu_ms_per_iteration"])
            if reference.get("final_chi2") and row.get("final_chi2") is not None:
                row[f"chi2_ratio_{suffix}"] = row["final_chi2"] / reference["final_chi2"]
    import io
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=fields, extrasaction="ignore")
    writer.writeheader()
    for row in rows:
        writer.writerow(row)
    write_atomically(os.path.join(out, "solver_comparison.csv"), buffer.getvalue())
    lines = ["| problem | run | solver | LM iterations (termination) | ms/iter | CPU ms/iter | "
             "CG it. | total s | CPU s | final chi2 | peak RSS MiB | CPU ms/iter ÷ Ceres "
             "iterative | chi2 ÷ Ceres iterative | CPU ms/iter ÷ CHOLMOD | chi2 ÷ CHOLMOD |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]

    def number(row, key, fmt):
        return fmt.format(row[key]) if row.get(key) is not None else "—"

    for row in rows:
        if "final_chi2" not in row:
            lines.append(f"| {row['problem']} | {row['run']} | — | failed ({row['exit']}) "
                         f"| — | — | — | — | {number(row, 'cpu_s', '{:.1f}')} | — | — | — | — "
                         "| — | — |")
            continue
        lines.append(
            f"| {row['problem']} | {row['run']} | {row.get('solver') or '—'} | "
            f"{row.get('iterations', '—')} ({row.get('termination', '—')}) | "
            f"{number(row, 'ms_per_iteration', '{:.1f}')} | "
            f"{number(row, 'cpu_ms_per_iteration', '{:.1f}')} | "
            f"{number(row, 'linear_iterations', '{}')} | {number(row, 'total_s', '{:.2f}')} | "
            f"{number(row, 'cpu_s', '{:.1f}')} | {row['final_chi2']:.6f} | "
            f"{number(row, 'peak_rss_mib', '{:.1f}')} | "
            f"{number(row, 'cpu_ms_ratio_vs_ceres_iterative', '{:.3f}')} | "
            f"{number(row, 'chi2_ratio_vs_ceres_iterative', '{:.6f}')} | "
            f"{number(row, 'cpu_ms_ratio_vs_cholmod', '{:.3f}')} | "
            f"{number(row, 'chi2_ratio_vs_cholmod', '{:.6f}')} |")
    write_atomically(os.path.join(out, "solver_comparison.md"), "\n".join(lines) + "\n")


if __name__ == "__main__":
    sys.exit(main())
