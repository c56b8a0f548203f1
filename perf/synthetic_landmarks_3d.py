#!/usr/bin/env python3
"""A synthetic 3-D landmark problem in g2o (VERTEX_SE3:QUAT, VERTEX_TRACKXYZ,
EDGE_SE3:QUAT, EDGE_SE3_TRACKXYZ) for timing the 3-D chunked solve
(docs/history/benchmarks-notebook-2026-11.md, "One chunked solve for 2-D
and 3-D").

A helix of N = 3000 poses (odometry only, pose 0 fixed), M = 30000 points,
each seen K = 6 times from poses within 10 of a random centre; noisy
measurements and initial guesses, seed 5.

Usage: perf/synthetic_landmarks_3d.py OUT.g2o
"""
import math
import random
import sys

random.seed(5)
random.seed(5)
N, M, K = 3000, 30000, 6
def quat_from_yaw(a):
    return (0.0, 0.0, math.sin(a/2), math.cos(a/2))
def rot(q, v):
    x,y,z,w = q
    # rotation matrix
    R = [[1-2*(y*y+z*z), 2*(x*y-z*w), 2*(x*z+y*w)],
         [2*(x*y+z*w), 1-2*(x*x+z*z), 2*(y*z-x*w)],
         [2*(x*z-y*w), 2*(y*z+x*w), 1-2*(x*x+y*y)]]
    return [sum(R[i][j]*v[j] for j in range(3)) for i in range(3)], R
poses = []
for i in range(N):
    a = 2*math.pi*i/300.0
    poses.append(((20*math.cos(a), 20*math.sin(a), 0.05*i), quat_from_yaw(a+math.pi/2)))
out = []
for i,(t,q) in enumerate(poses):
    n = 0.0 if i == 0 else 0.05
    out.append("VERTEX_SE3:QUAT %d %f %f %f %f %f %f %f" % (i, t[0]+random.gauss(0,n), t[1]+random.gauss(0,n), t[2]+random.gauss(0,n), q[0], q[1], q[2], q[3]))
out.append("FIX 0")
info6 = "100 0 0 0 0 0 100 0 0 0 0 100 0 0 0 400 0 0 400 0 400"
for i in range(N-1):
    (t0,q0),(t1,q1) = poses[i], poses[i+1]
    d = [t1[k]-t0[k] for k in range(3)]
    # relative translation in frame 0: R0^T d
    _, R0 = rot(q0, [0,0,0])
    dl = [sum(R0[j][k]*d[j] for j in range(3)) for k in range(3)]
    da = 2*math.pi/300.0
    qr = quat_from_yaw(da)
    out.append("EDGE_SE3:QUAT %d %d %f %f %f %f %f %f %f %s" % (i, i+1, dl[0]+random.gauss(0,0.01), dl[1]+random.gauss(0,0.01), dl[2]+random.gauss(0,0.01), qr[0], qr[1], qr[2], qr[3], info6))
info3 = "50 0 0 50 0 50"
for m in range(M):
    c = random.randrange(N)
    t,q = poses[c]
    p = [t[0]+random.uniform(-8,8), t[1]+random.uniform(-8,8), t[2]+random.uniform(-3,3)]
    out.append("VERTEX_TRACKXYZ %d %f %f %f" % (N+m, p[0]+random.gauss(0,0.2), p[1]+random.gauss(0,0.2), p[2]+random.gauss(0,0.2)))
    for k in range(K):
        i = min(N-1, max(0, c + random.randint(-10, 10)))
        t,q = poses[i]
        _, R = rot(q, [0,0,0])
        d = [p[j]-t[j] for j in range(3)]
        z = [sum(R[j][k2]*d[j] for j in range(3)) + random.gauss(0,0.05) for k2 in range(3)]
        out.append("EDGE_SE3_TRACKXYZ %d %d 0 %f %f %f %s" % (i, N+m, z[0], z[1], z[2], info3))
open(sys.argv[1], 'w').write("\n".join(out)+"\n")
