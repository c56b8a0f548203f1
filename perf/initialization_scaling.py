#!/usr/bin/env python3
"""Initialization time against the number of poses (issue 20).

For each size N, simulates one campus run of N poses (`graphslam simulate
--poses N`, features derived from the campus size, so observations per pose
stay about constant) and times `graphslam solve LOG --initialization I
--max-iterations 0` for the default's initialization (incremental) and, up to
--progressive-max poses, for progressive initialization (whole prefixes),
from the report's initialization_cpu_seconds and
stage_seconds.progressive_initialization (wall). Writes OUT/initialization.csv,
OUT/initialization.md (a Markdown table with the fitted exponents) and
OUT/initialization.png (build/bin/initialization_plot).

The fitted exponent b of t = a N^b is the least-squares slope of log t
against log N over the sizes from 10^4 poses on (below, fixed costs dominate).

usage: perf/initialization_scaling.py --build build --out OUT
         [--sizes 1000 3000 10000 30000 100000 300000] [--progressive-max 30000]
"""
import argparse
import json
import math
import os
import subprocess
import sys


def run(command, ok=(0,)):
    result = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if result.returncode not in ok:
        sys.exit('failed (%d): %s\n%s' % (result.returncode, ' '.join(command), result.stderr))


def slope(points):
    xs = [math.log(n) for n, t in points]
    ys = [math.log(t) for n, t in points]
    k = len(xs)
    if k < 2:
        return float('nan')
    sx, sy = sum(xs), sum(ys)
    sxx = sum(x * x for x in xs)
    sxy = sum(x * y for x, y in zip(xs, ys))
    return (k * sxy - sx * sy) / (k * sxx - sx * sx)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument('--build', default='build')
    parser.add_argument('--out', required=True)
    parser.add_argument('--sizes', type=int, nargs='+',
                        default=[1000, 3000, 10000, 30000, 100000, 300000])
    parser.add_argument('--progressive-max', type=int, default=30000)
    parser.add_argument('--seed', type=int, default=1)
    args = parser.parse_args()
    graphslam = os.path.join(args.build, 'bin', 'graphslam')
    os.makedirs(args.out, exist_ok=True)
    rows = []
    for n in args.sizes:
        sim = os.path.join(args.out, 'sim%d' % n)
        if not os.path.exists(os.path.join(sim, 'log.graphslam')):
            run([graphslam, 'simulate', '--poses', str(n), '--seed', str(args.seed), '-o', sim, '-q'])
        row = {'poses': n}
        for init in ('incremental', 'progressive'):
            if init == 'progressive' and n > args.progressive_max:
                row[init + '_seconds'] = row[init + '_cpu_seconds'] = 0.0
                continue
            report = os.path.join(args.out, 'report_%s_%d.json' % (init, n))
            run([graphslam, 'solve', os.path.join(sim, 'log.graphslam'), '--initialization', init,
                 '--max-iterations', '0', '-q', '--report', report], ok=(0, 4))  # 4: the cap
            r = json.load(open(report))
            row['observations'] = r['observations']
            row[init + '_seconds'] = r['stage_seconds']['progressive_initialization']
            row[init + '_cpu_seconds'] = r['initialization_cpu_seconds']
            if init == 'incremental':
                inc = r['incremental_initialization']
                row['stages'] = inc['stages']
                row['most_poses_solved_in_a_stage'] = inc['most_poses_solved_in_a_stage']
        print(row, flush=True)
        rows.append(row)

    columns = ['poses', 'observations', 'stages', 'most_poses_solved_in_a_stage',
               'incremental_seconds', 'incremental_cpu_seconds', 'progressive_seconds',
               'progressive_cpu_seconds']
    with open(os.path.join(args.out, 'initialization.csv'), 'w') as f:
        f.write(','.join(columns) + '\n')
        for row in rows:
            f.write(','.join(str(row.get(c, 0)) for c in columns) + '\n')
    fits = {}
    for init in ('incremental', 'progressive'):
        points = [(row['poses'], row[init + '_cpu_seconds']) for row in rows
                  if row['poses'] >= 10000 and row[init + '_cpu_seconds'] > 0]
        fits[init] = slope(points)
    with open(os.path.join(args.out, 'initialization.md'), 'w') as f:
        f.write('| poses | observations | stages | most poses solved in a stage | '
                'incremental CPU s (wall s) | CPU us / pose | progressive CPU s (wall s) |\n')
        f.write('|---:|---:|---:|---:|---:|---:|---:|\n')
        for row in rows:
            progressive = ('%.2f (%.2f)' % (row['progressive_cpu_seconds'],
                                            row['progressive_seconds'])
                           if row['progressive_cpu_seconds'] > 0 else '-')
            f.write('| %d | %d | %d | %d | %.2f (%.2f) | %.0f | %s |\n' % (
                row['poses'], row['observations'], row['stages'],
                row['most_poses_solved_in_a_stage'], row['incremental_cpu_seconds'],
                row['incremental_seconds'], 1e6 * row['incremental_cpu_seconds'] / row['poses'],
                progressive))
        f.write('\nFitted exponent b of CPU s = a N^b (sizes >= 10^4): incremental %.2f, '
                'progressive %.2f\n' % (fits['incremental'], fits['progressive']))
    run([os.path.join(args.build, 'bin', 'initialization_plot'),
         os.path.join(args.out, 'initialization.csv'), os.path.join(args.out, 'initialization.png')])
    print(open(os.path.join(args.out, 'initialization.md')).read())


if __name__ == '__main__':
    main()
