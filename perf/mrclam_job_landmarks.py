#!/usr/bin/env python3
"""Landmark and per-robot errors of an MRCLAM job against the dataset's survey.

Usage: perf/mrclam_job_landmarks.py OUTPUT_FOLDER MRCLAM_FOLDER

Reads OUTPUT/report.json (joint_trajectory_errors of component 0: the ONE
rigid alignment of all runs) and OUTPUT/features.csv, and compares the
landmarks with Landmark_Groundtruth.dat under that alignment. Dataset 1's
labels 11 and 17 are swapped relative to the survey (docs/benchmarks.md,
MRCLAM robot 1), so the two are exchanged before comparing.
"""
import json
import math
import sys


def main():
    out, data = sys.argv[1], sys.argv[2]
    report = json.load(open(out + '/report.json'))
    joint = report['joint_trajectory_errors'][0]
    a = joint['alignment']
    c, s = math.cos(a['theta']), math.sin(a['theta'])
    truth = {}
    for line in open(data + '/Landmark_Groundtruth.dat'):
        if not line.strip() or line.strip().startswith('#'):
            continue
        f = line.split()
        truth[int(f[0])] = (float(f[1]), float(f[2]))
    truth[11], truth[17] = truth[17], truth[11]
    squared, count = 0.0, 0
    for line in open(out + '/features.csv'):
        f = line.strip().split(',')
        if f[0] == 'id' or len(f) < 3:
            continue
        landmark = int(f[0])
        if landmark not in truth or (len(f) >= 5 and f[4] == '1'):
            continue
        x, y = float(f[1]), float(f[2])
        gx, gy = c * x - s * y + a['x'], s * x + c * y + a['y']
        squared += (gx - truth[landmark][0]) ** 2 + (gy - truth[landmark][1]) ** 2
        count += 1
    for run in joint['runs']:
        print('%s: position RMSE %.4f m, heading RMSE %.4f rad (joint alignment)' %
              (run['name'], run['position_rmse_m'], run['heading_rmse_rad']))
    print('all runs: position RMSE %.4f m, heading RMSE %.4f rad' %
          (joint['position_rmse_m'], joint['heading_rmse_rad']))
    print('landmarks: %d, RMSE %.4f m' % (count, math.sqrt(squared / count)))


if __name__ == '__main__':
    main()
