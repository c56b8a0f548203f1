#!/usr/bin/env python3
"""An MRCLAM folder with fewer poses per robot, for robots on different clocks.

Usage: perf/mrclam_thin_poses.py MRCLAM_FOLDER OUTPUT_FOLDER [STRIDE]

Each robot keeps every STRIDE-th odometry record (default 5: 10 Hz from the
50 Hz files) plus the records at the stamps of its own measurements, so every
measurement still has its observer's pose at its stamp while the robot it sees
mostly has none there: a sighting falls between two of the observed robot's
poses (tools/job/robot_sightings.h interpolates it). A kept record's control
(v, omega) is the dt-weighted mean of the records it replaces. Measurement,
ground-truth, barcode and landmark files are copied unchanged. Run the same
job (tools/setup/mrclam_job.yaml with its paths pointing at OUTPUT_FOLDER) on
two builds to compare sightings interpolated with ones snapped or dropped.
"""
import os
import shutil
import sys


def read_rows(path):
    rows = []
    for line in open(path):
        if not line.strip() or line.lstrip().startswith('#'):
            continue
        rows.append(line.split())
    return rows


def main():
    source, target = sys.argv[1], sys.argv[2]
    stride = int(sys.argv[3]) if len(sys.argv) > 3 else 5
    os.makedirs(target, exist_ok=True)
    for name in os.listdir(source):
        if not name.endswith('_Odometry.dat'):
            shutil.copyfile(os.path.join(source, name), os.path.join(target, name))
    for robot in range(1, 6):
        odometry = os.path.join(source, 'Robot%d_Odometry.dat' % robot)
        if not os.path.exists(odometry):
            continue
        rows = read_rows(odometry)
        measured = {row[0] for row in read_rows(os.path.join(source, 'Robot%d_Measurement.dat' % robot))}
        keep = [k for k, row in enumerate(rows)
                if k % stride == 0 or row[0] in measured or k == len(rows) - 1]
        with open(os.path.join(target, 'Robot%d_Odometry.dat' % robot), 'w') as out:
            out.write('# every %d-th record of %s and those at its measurements\n' % (stride, odometry))
            for j, k in enumerate(keep):
                end = keep[j + 1] if j + 1 < len(keep) else k + 1
                if end == k + 1:
                    v, omega = float(rows[k][1]), float(rows[k][2])
                else:
                    span = float(rows[end][0]) - float(rows[k][0])
                    v = omega = 0.0
                    for i in range(k, end):
                        dt = float(rows[i + 1][0]) - float(rows[i][0])
                        v += float(rows[i][1]) * dt
                        omega += float(rows[i][2]) * dt
                    v, omega = v / span, omega / span
                out.write('%s %.9g %.9g\n' % (rows[k][0], v, omega))
        print('robot %d: %d of %d poses' % (robot, len(keep), len(rows)))


if __name__ == '__main__':
    main()
