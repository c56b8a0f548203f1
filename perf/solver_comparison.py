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
guess (paper Table 1), every report written with --report. It writes
OUT/solver_comparison.csv (one row per run) and OUT/solver_comparison.md (the
table of docs/benchmarks.md): ms per iteration (mean of per_iteration[].seconds),
total seconds (the report's `seconds`: read to report), CPU seconds of the
whole process (user + system; the fairer figure on a loaded machine), final
chi2, peak RSS,
and the ratios of ours/pcg to Ceres ITERATIVE_SCHUR: time per iteration, and
final chi2 (the target: <= 0.5 at the same chi2 within 0.1 %).

  perf/solver_comparison.py --bin build/bin --out /tmp/cmp \
      [--problems intel,M3500,city10000,victoria,sim1e5] [--skip RUN,...] [--threads N]
      [--timeout S] [--max-iterations N] [--pcg-eta-max E]

Simulated problems (sim1e4, sim1e5, sim1e6) are generated once into OUT with
`graphslam simulate -o DIR --poses N --features M --format g2o --gps-every 25
--alpha 1e-4 1e-5 3e-7 1e-4 3e-7 1e-4` (see SIMULATED).
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
SIMULATED = {"sim1e4": (10000, 10000), "sim1e5": (20000, 100000),
             "sim1e6": (200000, 1000000)}
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


def command(run, binaries, path, report, threads, max_iterations=200, pcg_eta_max=None):
    ours = [f"{binaries}/graphslam", "solve", path, "--initialization", "odometry",
            "--max-iterations", str(max_iterations), "--threads", str(threads), "--report",
            report, "-q"]
    eta = [] if pcg_eta_max is None else ["--pcg-eta-max", str(pcg_eta_max)]
    ceres = [f"{binaries}/graphslam_ceres_peer", path, "--threads", str(threads),
             "--max-iterations", str(max_iterations), "--report", report, "-q"]
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
    poses, features = SIMULATED[name]
    folder = os.path.join(out, name)
    graph = os.path.join(folder, "graph.g2o")
    if not os.path.exists(graph):
        subprocess.run([f"{binaries}/graphslam", "simulate", "-o", folder, "--poses", str(poses),
                        "--features", str(features), "--format", "g2o", "-q"] + SIMULATE_NOISE,
                       check=True)
    return graph


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
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    skip = set(filter(None, args.skip.split(",")))
    rows = []
    for name in args.problems.split(","):
        path = problem_path(name, args.bin, args.out)
        for run in RUNS:
            if run in skip:
                continue
            report = os.path.join(args.out, f"{name}_{run.replace('/', '_')}.json")
            cmd = command(run, args.bin, path, report, args.threads, args.max_iterations,
                          args.pcg_eta_max)
            start = time.monotonic()
            # CPU seconds of the child (user + system, whole process: reading
            # the input included): on a shared, loaded machine the fairer
            # figure than wall-clock time, which counts the waits for a core.
            children_before = resource.getrusage(resource.RUSAGE_CHILDREN)
            try:
                result = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                        text=True, timeout=args.timeout)
                exit_code = result.returncode
            except subprocess.TimeoutExpired:
                exit_code = "timeout"
            wall = time.monotonic() - start
            children_after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu = (children_after.ru_utime - children_before.ru_utime +
                   children_after.ru_stime - children_before.ru_stime)
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
            rows.append(row)
            print(json.dumps({k: v for k, v in row.items() if k != "command"}), flush=True)
            write_outputs(rows, args.out)
    return 0


def write_outputs(rows, out):
    fields = ["problem", "run", "solver", "exit", "iterations", "termination", "ms_per_iteration",
              "linear_iterations", "total_s", "final_chi2", "peak_rss_mib",
              "ms_ratio_vs_ceres_iterative", "chi2_ratio_vs_ceres_iterative", "wall_s", "cpu_s",
              "command"]
    # Ratios of every run to Ceres ITERATIVE_SCHUR on the same problem: the
    # tight run if it finished, else the default one.
    by_problem = {}
    for row in rows:
        by_problem.setdefault(row["problem"], {})[row["run"]] = row
    for row in rows:
        runs = by_problem[row["problem"]]
        peer = runs.get("ceres/iterative_schur_tight")
        if peer is None or "ms_per_iteration" not in peer:
            peer = runs.get("ceres/iterative_schur")
        if peer and "ms_per_iteration" in peer and "ms_per_iteration" in row:
            row["ms_ratio_vs_ceres_iterative"] = row["ms_per_iteration"] / peer["ms_per_iteration"]
            row["chi2_ratio_vs_ceres_iterative"] = row["final_chi2"] / peer["final_chi2"]
    lines = []
    import io
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=fields, extrasaction="ignore")
    writer.writeheader()
    for row in rows:
        writer.writerow(row)
    write_atomically(os.path.join(out, "solver_comparison.csv"), buffer.getvalue())
    lines.append("| problem | run | solver | LM iterations (termination) | ms/iter | CG it. | "
                 "total s | CPU s | final chi2 | peak RSS MiB | ms/iter ÷ Ceres iterative | "
                 "chi2 ÷ Ceres iterative |")
    lines.append("|---|---|---|---|---|---|---|---|---|---|---|---|")

    def number(row, key, fmt):
        return fmt.format(row[key]) if row.get(key) is not None else "—"

    for row in rows:
        if "ms_per_iteration" not in row:
            lines.append(f"| {row['problem']} | {row['run']} | — | failed ({row['exit']}) "
                         "| — | — | — | — | — | — | — | — |")
            continue
        lines.append(
            f"| {row['problem']} | {row['run']} | {row['solver']} | {row['iterations']} "
            f"({row['termination']}) | {row['ms_per_iteration']:.1f} | {row['linear_iterations']} "
            f"| {row['total_s']:.2f} | {row['cpu_s']:.1f} | {row['final_chi2']:.6f} | "
            f"{row['peak_rss_mib']:.1f} | "
            f"{number(row, 'ms_ratio_vs_ceres_iterative', '{:.3f}')} | "
            f"{number(row, 'chi2_ratio_vs_ceres_iterative', '{:.6f}')} |")
    write_atomically(os.path.join(out, "solver_comparison.md"), "\n".join(lines) + "\n")


if __name__ == "__main__":
    sys.exit(main())
