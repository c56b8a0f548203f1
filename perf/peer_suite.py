#!/usr/bin/env python3
"""Ours against peers on the everyday pose-graph suite, in one go (issue 25).

Runs `graphslam solve FILE` with default options on each problem of the suite,
Ceres Solver (Debian's libceres-dev) always, and, when pointed at them, the
other peers on the same files:
  ceres                       perf/ceres_peer, Levenberg-Marquardt with
                              SPARSE_NORMAL_CHOLESKY (CHOLMOD), function
                              tolerance 1e-6 (ours) and Ceres' defaults
                              otherwise (docs/peers.md); the binaries
                              graphslam_ceres_peer and graphslam_ceres_peer_3d
                              beside --graphslam, built there by this script
                              (cmake --build) when missing; CERES_PEER and
                              CERES_PEER_3D point elsewhere
  G2O_BIN=/path/to/g2o        g2o's command-line app (built from source, not in
                              Debian): `g2o -i -1 -ig MAX -gain 1e-6 -v -solver S FILE`
                              for S in G2O_SOLVERS (default
                              "gn_var_cholmod lm_var_cholmod"); MAX is
                              G2O_MAX_ITERATIONS (default 1000). -i -1 stops
                              on a relative chi2 gain below 1e-6 (our
                              --function-tolerance).
  GTSAM_PEER=/path/to/graphslam_gtsam_peer
                              perf/gtsam_peer, built against GTSAM (from
                              source, not in Debian; configure the build with
                              -DGTSAM_DIR=PREFIX/lib/cmake/GTSAM): Gauss-Newton
                              and Levenberg-Marquardt (GTSAM_OPTIMIZERS,
                              default "gn lm"), relative error tolerance 1e-6;
                              its chi2 is evaluated with graphslam's models.
Each configuration runs RUNS times (default 5), interleaved: round r runs
every configuration on every file before round r+1 starts, so a burst of load
from other work on the machine spreads over all of them. Wall time is the
whole process (start to exit), measured here; CPU time is the process's user
+ system time (getrusage of the waited-for children, so the threads of every
configuration count), which depends far less on the load of a shared machine
than wall time; chi2 is the configuration's final chi2 (ours and Ceres: the
report; g2o: the last `chi2=` line of -v).

Writes OUT/peer_suite.csv (one row per run) and OUT/peer_suite.md: per file,
the median wall and CPU times of each configuration, its chi2 and
iterations, and ours / best peer (median wall and CPU time ratios, each
against the peer fastest by that measure, and chi2 difference in %).

  perf/peer_suite.py --graphslam build/bin/graphslam --out /tmp/peers \
      [--datasets ../shared/datasets] [--runs 5] [--problems intel,M3500,...]
      [--ours-args "--solver cholmod"]
"""
import argparse
import csv
import json
import os
import re
import resource
import shlex
import statistics
import subprocess
import sys
import time

# name -> path under the datasets folder, dimension
SUITE = [
    ("intel", "freiburg_course_g2o/intel.g2o", 2),
    ("M3500", "freiburg_course_g2o/input_M3500_g2o.g2o", 2),
    ("city10000", "sesync_posegraphs/city10000.g2o", 2),
    ("parking-garage", "sesync_posegraphs/parking-garage.g2o", 3),
    ("sphere2500", "sesync_posegraphs/sphere2500.g2o", 3),
    ("torus3D", "sesync_posegraphs/torus3D.g2o", 3),
    ("victoriaPark", "victoria_park/victoriaPark-full.g2o", 2),
]

CHI2_RE = re.compile(r"chi2=\s*([0-9.eE+-]+)")
ITER_RE = re.compile(r"iteration=\s*(\d+)")


def report_parser(report):
    """Parser of a run that writes a JSON report (ours, the Ceres peer)."""
    def parse(out, err):
        with open(report) as f:
            r = json.load(f)
        os.remove(report)
        return r["final_chi2"], r["iterations"]
    return parse


def children_cpu_seconds():
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_timed(cmd, timeout):
    """(wall s, CPU s, exit code, stdout, stderr) of one run."""
    cpu_start = children_cpu_seconds()
    start = time.perf_counter()
    try:
        proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              timeout=timeout)
        code, out, err = proc.returncode, proc.stdout, proc.stderr
    except subprocess.TimeoutExpired as e:
        code = "timeout"
        out = e.stdout.decode() if isinstance(e.stdout, bytes) else (e.stdout or "")
        err = e.stderr.decode() if isinstance(e.stderr, bytes) else (e.stderr or "")
    wall = time.perf_counter() - start
    return wall, children_cpu_seconds() - cpu_start, code, out, err


def configurations(args, dim):
    """(name, function(path, scratch) -> (cmd, parse(out, err) -> (chi2, iterations)))"""
    configs = []

    def ours(path, scratch):
        report = os.path.join(scratch, "ours.json")
        cmd = [args.graphslam, "solve", path, "--report", report, "-q"] + shlex.split(
            args.ours_args)

        return cmd, report_parser(report)
    configs.append(("graphslam", ours))

    g2o = os.environ.get("G2O_BIN")
    if g2o:
        max_iterations = os.environ.get("G2O_MAX_ITERATIONS", "1000")
        for solver in os.environ.get("G2O_SOLVERS", "gn_var_cholmod lm_var_cholmod").split():
            def g2o_run(path, scratch, solver=solver):
                cmd = [g2o, "-i", "-1", "-ig", max_iterations, "-gain", "1e-6", "-v",
                       "-solver", solver, path]

                def parse(out, err):
                    text = out + err
                    chi2 = CHI2_RE.findall(text)
                    its = ITER_RE.findall(text)
                    return (float(chi2[-1]) if chi2 else float("nan"),
                            int(its[-1]) + 1 if its else 0)
                return cmd, parse
            configs.append(("g2o " + solver, g2o_run))

    gtsam = os.environ.get("GTSAM_PEER")
    if gtsam:
        for optimizer in os.environ.get("GTSAM_OPTIMIZERS", "gn lm").split():
            def gtsam_run(path, scratch, optimizer=optimizer):
                report = os.path.join(scratch, "gtsam.json")
                cmd = [gtsam, path, "--report", report, "-q", "--optimizer", optimizer,
                       "--relative-error-tol", "1e-6"] + (["--3d"] if dim == 3 else [])
                return cmd, report_parser(report)
            configs.append(("gtsam " + optimizer, gtsam_run))

    ceres = args.ceres_peers[dim]

    def ceres_run(path, scratch):
        report = os.path.join(scratch, "ceres.json")
        cmd = [ceres, path, "--report", report, "-q"]
        if dim == 2:
            cmd += ["--linear-solver", "sparse_normal_cholesky"]
        else:  # the 3-D peer's own defaults are 1e-12 (a reference run)
            cmd += ["--function-tolerance", "1e-6", "--gradient-tolerance", "1e-10",
                    "--parameter-tolerance", "1e-8"]
        return cmd, report_parser(report)
    configs.append(("ceres", ceres_run))
    return configs


def summary_lines(rows, problems):
    """The table: per problem and configuration the medians, and for ours
    the ratios to the best peer. The best peer is the fastest of the peers
    whose chi2 is within 0.1 % of the lowest chi2 any peer reached: a peer
    that stops far above another peer's result (a diverged Gauss-Newton,
    an iteration cap) has not solved the problem, however fast it stopped."""
    lines = ["| problem | configuration | median wall s | median CPU s | chi2 | iterations | "
             "wall / best peer | CPU / best peer | chi2 vs best peer | best peer |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for name in problems:
        by_config = {}
        for r in rows:
            if r[0] == name:
                by_config.setdefault(r[1], []).append(r)
        wall = {c: statistics.median(float(r[3]) for r in rs) for c, rs in by_config.items()}
        cpu = {c: statistics.median(float(r[7]) for r in rs) for c, rs in by_config.items()}
        chi2 = {c: float(rs[-1][5]) for c, rs in by_config.items()}
        iterations = {c: rs[-1][6] for c, rs in by_config.items()}
        peers = [c for c in by_config if c != "graphslam" and chi2[c] == chi2[c]]  # not NaN
        best_chi2 = min((chi2[c] for c in peers), default=None)
        solved = [c for c in peers if chi2[c] <= best_chi2 * 1.001 + 1e-9]
        best_wall = min(solved, key=lambda c: wall[c], default=None)
        best_cpu = min(solved, key=lambda c: cpu[c], default=None)
        for c in by_config:
            wall_ratio = cpu_ratio = chi2_delta = best = ""
            if c == "graphslam" and best_wall:
                wall_ratio = f"{wall[c] / wall[best_wall]:.2f}x"
                cpu_ratio = f"{cpu[c] / cpu[best_cpu]:.2f}x"
                chi2_delta = f"{100 * (chi2[c] - best_chi2) / best_chi2:+.3f} %"
                best = best_wall
            lines.append(f"| {name} | {c} | {wall[c]:.3f} | {cpu[c]:.3f} | "
                         f"{chi2[c]:.6g} | {iterations[c]} | {wall_ratio} | {cpu_ratio} | "
                         f"{chi2_delta} | {best} |")
    return lines


def ceres_peers(graphslam):
    """{dimension: Ceres peer binary}: CERES_PEER / CERES_PEER_3D, else the
    binaries beside `graphslam`, built with its build folder's CMake when
    missing (perf/CMakeLists.txt adds them when Ceres is found)."""
    bin_dir = os.path.dirname(os.path.abspath(graphslam))
    peers = {2: os.environ.get("CERES_PEER") or os.path.join(bin_dir, "graphslam_ceres_peer"),
             3: os.environ.get("CERES_PEER_3D") or os.path.join(bin_dir, "graphslam_ceres_peer_3d")}
    missing = [os.path.basename(p) for p in peers.values() if not os.access(p, os.X_OK)]
    build_dir = os.path.dirname(bin_dir)
    if missing and os.path.exists(os.path.join(build_dir, "CMakeCache.txt")):
        print(f"building {' '.join(missing)} in {build_dir}", flush=True)
        subprocess.run(["cmake", "--build", build_dir, "-j2", "--target"] + missing, check=False)
    missing = [p for p in peers.values() if not os.access(p, os.X_OK)]
    if missing:
        sys.exit(f"Ceres peer(s) {missing} not found: install Ceres (apt-get install "
                 "libceres-dev, or GRAPHSLAM_WITH_CERES=1 tools/setup/install_dependencies.sh), "
                 "reconfigure the build, or set CERES_PEER / CERES_PEER_3D")
    return peers


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    here = os.path.dirname(os.path.abspath(__file__))
    parser.add_argument("--graphslam", default=os.path.join(here, "..", "build", "bin", "graphslam"))
    parser.add_argument("--datasets", default=os.path.join(here, "..", "..", "shared", "datasets"))
    parser.add_argument("--out", required=True)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--problems", default=",".join(name for name, _, _ in SUITE))
    parser.add_argument("--ours-args", default="", help="extra options for graphslam solve")
    parser.add_argument("--timeout", type=float, default=600)
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    wanted = args.problems.split(",")
    unknown = [w for w in wanted if w not in [name for name, _, _ in SUITE]]
    if unknown:
        sys.exit(f"unknown problem(s) {unknown}; expected some of "
                 f"{[name for name, _, _ in SUITE]}")
    suite = [(n, os.path.join(args.datasets, p), d) for n, p, d in SUITE if n in wanted]
    args.ceres_peers = ceres_peers(args.graphslam)
    for name, path, _ in suite:
        if not os.path.exists(path):
            sys.exit(f"{name}: dataset {path} not found (--datasets)")

    rows = []
    with open(os.path.join(args.out, "peer_suite.csv"), "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["problem", "config", "run", "wall_seconds", "exit", "chi2", "iterations",
                         "cpu_seconds"])
        for run in range(1, args.runs + 1):
            for name, path, dim in suite:
                for config, make in configurations(args, dim):
                    cmd, parse = make(path, args.out)
                    wall, cpu, code, out, err = run_timed(cmd, args.timeout)
                    try:
                        chi2, iterations = parse(out, err)
                    except (OSError, ValueError, KeyError):
                        chi2, iterations = float("nan"), 0
                    row = [name, config, run, f"{wall:.4f}", code, f"{chi2:.10g}", iterations,
                           f"{cpu:.4f}"]
                    writer.writerow(row)
                    f.flush()
                    rows.append(row)
                    print(" ".join(str(x) for x in row), flush=True)

    lines = summary_lines(rows, [name for name, _, _ in suite])
    table = "\n".join(lines) + "\n"
    with open(os.path.join(args.out, "peer_suite.md"), "w") as f:
        f.write(f"Medians of {args.runs} interleaved runs; wall and CPU (user + system) time of "
                f"the whole process; load average {os.getloadavg()[0]:.1f} at the end.\n\n")
        f.write(table)
    print(table)


if __name__ == "__main__":
    main()
