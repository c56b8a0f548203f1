#!/usr/bin/env python3
"""The scaling model of the distributed solve (docs/distributed.md, "Scaling model").

Reads what perf/distributed_benchmark.py measured (OUT/distributed.json and
one report, OUT/np1_run0.json, for the store's sizes) and prints

  1. the constants it takes from the np 1 runs: seconds per observation of a
     chunk pass (one core), seconds per stored 3x3 block of S per CG iteration
     (product + block Jacobi / ILU), CG iterations per solve; from np 2 and 4:
     peak RSS per rank beyond the base, per feature the rank owns (ranks 1..
     N-1, which hold only their own features), and rank 0's extra bytes per
     feature of the store (it also reads, holds and writes them all);
  2. its prediction for np 2 and 4 on this machine beside the measurement;
  3. memory per rank, bytes sent per rank per iteration and seconds per
     iteration for 10^9 and 10^10 features on 16 to 256 nodes, one rank per
     node with CORES threads for the chunk passes (the KSP runs on one core
     per rank: PETSc is not threaded), over a network of LATENCY seconds and
     BANDWIDTH bytes/s, with the store's proportions (observations, poses and
     S blocks per feature as measured).

Per rank and iteration (one fused chunk pass per accepted iteration), for
n = 3 P pose unknowns, F features, O observations, B stored blocks of S,
k CG iterations, N ranks:

  compute   c_obs O / (N CORES) + k c_block B / N
  latency   (k 2 + s) LATENCY log2 N       (2 reductions per CG iteration, s others)
  bytes     sums 16 n + exchange e_pose P (N-1)/N + gather 8 n (N-1)/N
            + checkpoint 18 F / N (every rank but 0: its own features and
            their two flags) + halo k h
  time      compute + latency + bytes / BANDWIDTH

e_pose (exchange bytes per pose) and h (halo bytes per CG iteration) are
taken from the np 2 and 4 runs. The measured np 2 and 4 rows here run on a
shared 2-core host, where BANDWIDTH and LATENCY are those of shared memory
under load, not of a network.

usage: perf/distributed_model.py OUT
environment: CORES (32), LATENCY (2e-6 s), BANDWIDTH (1.0e10 bytes/s),
  BASE_MIB (80: a rank's RSS on a tiny store, MPI and PETSc loaded; measured
  on the campus store's ranks)

Memory per rank: BASE + m F / N for ranks 1..N-1 (m: the median over
ranks 1.. of np 2 and 4 of (peak RSS - BASE) / (F / N)), rank 0: that plus
r F (r: the median over np 1, 2, 4 of (rank 0's peak RSS - BASE - m F / N)
/ F, at least the 31 B per feature rank 0 holds by the code); both + 288 B per pose (the replicated n-vectors: poses, gradient, diagonal,
rhs, damping, step, candidate; from the code) + 216 B per S block / N (the
rank's local S_r, its PETSc rows, the exchange's slots; from the code).
"""
import json
import math
import os
import statistics
import sys

ROOT_BYTES = 31


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    cores = int(os.environ.get("CORES", "32"))
    latency = float(os.environ.get("LATENCY", "2e-6"))
    bandwidth = float(os.environ.get("BANDWIDTH", "1.0e10"))
    with open(os.path.join(out, "distributed.json")) as f:
        runs = {int(n): rows for n, rows in json.load(f).items()}
    with open(os.path.join(out, "np1_run0.json")) as f:
        report = json.load(f)
    P = report["poses"]
    F = report["features"]
    O = report["observations"]
    B = report["reduced_nonzero_blocks"]
    n = 3 * P
    med = statistics.median

    one = runs[1]
    # CPU seconds, not wall: on the shared host the wall counts waits for a
    # core. The chunk passes' CPU is the process's minus the KSP's (and so
    # includes reading the problem file and the start: an upper bound).
    passes = med([r["ranks"][0]["cpu_s"] - r["ranks"][0]["ksp_cpu_s"] for r in one])
    ksp = med([r["ranks"][0]["ksp_cpu_s"] for r in one])
    cg = med([r["cg_iterations"] for r in one])
    c_obs = passes / O
    c_block = ksp / (cg * B)
    # Exchange bytes per pose and halo bytes per CG iteration from N > 1.
    e_pose, h_per_rank = [], {}
    for N, rows in runs.items():
        if N == 1:
            continue
        rep = rows[0]
        with open(os.path.join(out, "np%d_run0.json" % N)) as f:
            per_rank = json.load(f)["distributed"]["per_rank"]
        its = max(1, rows[0]["iterations"])
        solves = per_rank[0]["solves"] / its
        e_pose.append(med([r["exchange_bytes_sent"] / max(1, r["solves"]) for r in per_rank]) /
                      (P * (N - 1) / N))
        h_per_rank[N] = med([r["halo_bytes_per_ksp_iteration"] for r in per_rank])
        del rep, solves
    e_pose = med(e_pose) if e_pose else 0.0
    # Peak RSS beyond the base: ranks 1.. per feature they own, rank 0's
    # extra per feature of the store.
    base = float(os.environ.get("BASE_MIB", "80")) * 2**20
    owned = med([(rank["peak_rss_mib"] * 2**20 - base) / (F / N)
                 for N, rows in runs.items() if N > 1 for r in rows
                 for rank in r["ranks"][1:]] or [0.0])
    root_fitted = med([(r["ranks"][0]["peak_rss_mib"] * 2**20 - base - owned * F / N) / F
                       for N, rows in runs.items() for r in rows])
    # The fit's split between owned and root bytes is loose (the base grows
    # with the store); rank 0 holds at least ROOT_BYTES per store feature by
    # the code: estimates 16, ids 8, three flags, every rank's numbering 4.
    root = max(root_fitted, ROOT_BYTES)

    print("## Constants measured (np 1 medians; RSS over np %s)\n" %
          ", ".join(str(k) for k in sorted(runs)))
    print("| store | poses %d, features %d, observations %d, S blocks %d |" % (P, F, O, B))
    print("|---|---|")
    print("| chunk passes per observation, one core (CPU) | %.3g s |" % c_obs)
    print("| KSP per S block per CG iteration (CPU) | %.3g s |" % c_block)
    print("| CG iterations per LM iteration | %.0f |" % cg)
    print("| exchange bytes per pose per solve (x (N-1)/N) | %.0f B |" % e_pose)
    print("| peak RSS per rank: base + per feature owned (ranks 1..N-1) | %.0f MiB + %.0f B "
          "per owned feature |" % (base / 2**20, owned))
    print("| rank 0 on top: per feature of the store | %.0f B (fitted %.0f B) |" %
          (root, root_fitted))

    print("\n## Prediction on this machine beside the measurement (one core per rank)\n")
    print("| ranks | predicted CPU s / it per rank | measured CPU s / it (rank 0, rank N-1) | "
          "measured wall s / it | measured wall passes + KSP s (rank 0) | measured wall "
          "communication s (rank 0) | predicted MB sent (rank 1) | measured MB sent (rank 1) |")
    print("|---|---|---|---|---|---|---|---|")
    for N in sorted(runs):
        rows = runs[N]
        compute = c_obs * O / N + cg * c_block * B / N
        sent = (0 if N == 1 else
                16 * n + e_pose * P * (N - 1) / N + 8 * n * (N - 1) / N + 18 * F / N)
        measured_sent = med([r["ranks"][min(1, N - 1)]["bytes_sent"] for r in rows])
        print("| %d | %.3f | %.3f, %.3f | %.3f | %.3f | %.3f | %.1f | %.1f |" % (
            N, compute, med([r["ranks"][0]["cpu_s"] for r in rows]),
            med([r["ranks"][N - 1]["cpu_s"] for r in rows]),
            med([r["s_per_iteration"] for r in rows]),
            med([r["ranks"][0]["passes_s"] + r["ranks"][0]["ksp_s"] for r in rows]),
            med([r["ranks"][0]["communication_s"] for r in rows]), sent / 1e6,
            measured_sent / 1e6))

    print("\n## Extrapolation: one rank per node, %d cores, latency %.0e s, bandwidth %.0e B/s\n"
          % (cores, latency, bandwidth))
    print("| features | nodes | memory per rank GB (ranks 1..N-1) | memory GB (rank 0) "
          "| GB sent per rank per iteration (of which checkpoint) | s / iteration "
          "(compute, network) | s / iteration without the checkpoint gather |")
    print("|---|---|---|---|---|---|---|")
    h_per_pose = (med(list(h_per_rank.values())) / P) if h_per_rank else 0.0
    for features in (1e9, 1e10):
        scale = features / F
        p, o, b = P * scale, O * scale, B * scale
        nn = 3 * p
        for N in (16, 64, 256):
            poses_and_s = 288 * p + 216 * b / N
            memory_owned = base + owned * features / N + poses_and_s
            memory_root = memory_owned + root * features
            checkpoint = 18 * features / N
            sent = 16 * nn + e_pose * p * (N - 1) / N + 8 * nn * (N - 1) / N + checkpoint
            halo = h_per_pose * p / N  # a band of the trajectory per rank: its boundary
            compute = c_obs * o / (N * cores) + cg * c_block * b / N
            network = ((2 * cg + 10) * latency * math.log2(N) + (sent + cg * halo) / bandwidth)
            print("| %.0e | %d | %.2f | %.1f | %.1f (%.1f) | %.1f (%.1f, %.1f) | %.1f |" % (
                features, N, memory_owned / 1e9, memory_root / 1e9, sent / 1e9, checkpoint / 1e9,
                compute + network, compute, network,
                compute + network - checkpoint / bandwidth))


if __name__ == "__main__":
    main()
