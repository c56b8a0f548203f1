#!/usr/bin/env python3
"""The distributed solve's costs per iteration (docs/distributed.md, "Measured").

For each rank count N (default 1 2 4), runs RUNS times, interleaved,
  mpirun --allow-run-as-root --oversubscribe -np N graphslam solve STORE/
      --streaming-poses 0 --initialization odometry --max-iterations ITERATIONS
      --threads 1 --report R.json -q
and prints, per N, the medians of: seconds per Levenberg-Marquardt iteration
(the report's optimize seconds / iterations), and per rank and iteration the
seconds of the chunk passes, the PETSc KSP solve, the communication (the
policy's MPI_Allreduce sums, the block exchange and assembly, the step's
all-gather, the checkpoint's feature gather; waits for slower ranks
included), the bytes each rank sent (sums, exchange, gather, checkpoint) and
the halo bytes the KSP's products bring in, and the peak RSS per rank.
Writes OUT/distributed.json (every run's per-rank figures) and prints a
Markdown table.

usage: perf/distributed_benchmark.py BUILD_DIR STORE OUT [N ...]
environment: RUNS (3), ITERATIONS (3), MPIEXEC (mpirun)
"""
import json
import os
import statistics
import subprocess
import sys


def run(build, store, out, ranks, index, iterations):
    report = os.path.join(out, "np%d_run%d.json" % (ranks, index))
    command = [os.environ.get("MPIEXEC", "mpirun"), "--allow-run-as-root", "--oversubscribe",
               "-np", str(ranks), os.path.join(build, "bin", "graphslam"), "solve", store,
               "--streaming-poses", "0", "--initialization", "odometry",
               "--max-iterations", str(iterations), "--threads", "1", "--report", report, "-q"]
    code = subprocess.call(command)
    if code not in (0, 4):  # 4: stopped at --max-iterations, outputs written
        sys.exit("failed (%d): %s" % (code, " ".join(command)))
    with open(report) as f:
        return json.load(f)


def figures(report):
    iterations = max(1, report["iterations"])
    per_rank = report["distributed"]["per_rank"]
    out = {"s_per_iteration": report["stage_seconds"]["optimize"] / iterations,
           "iterations": report["iterations"], "final_chi2": report["final_chi2"],
           "cg_iterations": sum(r["ksp_iterations"] for r in per_rank) / len(per_rank) / iterations,
           "ranks": []}
    for r in per_rank:
        communication = (r["reduction_seconds"] + r["exchange_seconds"] + r["gather_seconds"] +
                         r["checkpoint_seconds"])
        sent = (r["reduction_bytes_sent"] + r["exchange_bytes_sent"] + r["gather_bytes_sent"] +
                r["checkpoint_bytes_sent"])
        out["ranks"].append({
            "passes_s": r["passes_seconds"] / iterations,
            "ksp_s": r["ksp_seconds"] / iterations,
            "communication_s": communication / iterations,
            "bytes_sent": sent / iterations,
            "halo_bytes_received": r["halo_bytes_received"] / iterations,
            "peak_rss_mib": r.get("peak_rss_bytes", 0) / 2**20,
            # CPU seconds of the whole process (its start included) and of the KSP.
            "cpu_s": r.get("cpu_seconds", 0) / iterations,
            "ksp_cpu_s": r.get("ksp_cpu_seconds", 0) / iterations})
    return out


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    build, store, out = sys.argv[1:4]
    counts = [int(n) for n in sys.argv[4:]] or [1, 2, 4]
    runs = int(os.environ.get("RUNS", "3"))
    iterations = int(os.environ.get("ITERATIONS", "3"))
    os.makedirs(out, exist_ok=True)
    results = {n: [] for n in counts}
    for index in range(runs):  # interleaved: the load drifts, the order does not bias
        for n in counts:
            results[n].append(figures(run(build, store, out, n, index, iterations)))
            print("np %d run %d: %.3f s/iteration" % (n, index, results[n][-1]["s_per_iteration"]),
                  file=sys.stderr, flush=True)
    with open(os.path.join(out, "distributed.json"), "w") as f:
        json.dump({str(n): results[n] for n in counts}, f, indent=2)

    def median(values):
        return statistics.median(values)

    print("| ranks | s / iteration | per rank: chunk passes s | KSP s | communication s | "
          "MB sent | KSP halo MB received | CG its / iteration | peak RSS MiB | CPU s (KSP CPU s) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for n in counts:
        rows = results[n]
        per = lambda key: ", ".join(
            "%.3g" % median([row["ranks"][r][key] for row in rows]) for r in range(n))
        mb = lambda key: ", ".join(
            "%.3g" % (median([row["ranks"][r][key] for row in rows]) / 1e6) for r in range(n))
        print("| %d | %.3f | %s | %s | %s | %s | %s | %.0f | %s | %s (%s) |" % (
            n, median([row["s_per_iteration"] for row in rows]), per("passes_s"), per("ksp_s"),
            per("communication_s"), mb("bytes_sent"), mb("halo_bytes_received"),
            median([row["cg_iterations"] for row in rows]), per("peak_rss_mib"), per("cpu_s"),
            per("ksp_cpu_s")))


if __name__ == "__main__":
    main()
