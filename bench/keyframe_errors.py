#!/usr/bin/env python3
"""Keyframe poses of a run against a simulated plot's truth, in the plot frame, unaligned.

Usage: bench/keyframe_errors.py PLOT_DIR [RUN_SUBDIR=process]
Reads RUN_SUBDIR/keyframes.tum and trajectory_truth.tum (nearest time). Reports the heading
error (azimuth of the optical axis), the error of the camera's azimuth about the origin, their
difference (the mount's yaw on the arm), the heading error's spread and its part faster than
+-15 keyframes, then a table around the turn: radial and height errors of the camera centre and
the errors of the optical axis' elevation (pitch) and of the x axis' elevation (roll).
"""
import math, sys
def rd(p):
    out=[]
    for l in open(p):
        if l.startswith('#') or not l.strip(): continue
        v=list(map(float,l.split())); out.append(v)
    return out
def rot(q):  # qx qy qz qw -> matrix
    x,y,z,w=q
    return [[1-2*(y*y+z*z),2*(x*y-z*w),2*(x*z+y*w)],[2*(x*y+z*w),1-2*(x*x+z*z),2*(y*z-x*w)],[2*(x*z-y*w),2*(y*z+x*w),1-2*(x*x+y*y)]]
plot = sys.argv[1]
sub = sys.argv[2] if len(sys.argv) > 2 else 'process'
est=rd(f'{plot}/{sub}/keyframes.tum'); tru=rd(f'{plot}/trajectory_truth.tum')
rows=[]
for e in est:
    t=min(tru,key=lambda r: abs(r[0]-e[0]))
    Re,Rt=rot(e[4:8]),rot(t[4:8])
    he=math.atan2(Re[1][2],Re[0][2]); ht=math.atan2(Rt[1][2],Rt[0][2])   # azimuth of optical axis
    pe=math.atan2(e[2],e[1]); pt=math.atan2(t[2],t[1])
    # camera x axis elevation (roll) and z axis elevation (pitch)
    rows.append((e[0], math.degrees(math.remainder(he-ht,2*math.pi)), math.degrees(math.remainder(pe-pt,2*math.pi)),
                 100*(math.hypot(e[1],e[2])-math.hypot(t[1],t[2])), 100*(e[3]-t[3]), math.degrees(pt),
                 math.degrees(math.asin(Re[2][2])-math.asin(Rt[2][2])), math.degrees(math.asin(Re[2][0])-math.asin(Rt[2][0]))))
n=len(rows)
mh=sum(r[1] for r in rows)/n; mp=sum(r[2] for r in rows)/n
print(f"{n} keyframes; mean heading err {mh:+.3f} deg, mean position-azimuth err {mp:+.3f} deg")
print("heading - position-az (mount yaw err) mean %+.3f sd %.3f" % (sum(r[1]-r[2] for r in rows)/n, (sum((r[1]-r[2]-(mh-mp))**2 for r in rows)/n)**.5))
print("heading err sd after mean %.3f" % ((sum((r[1]-mh)**2 for r in rows)/n)**.5))
# local variation: heading error minus its running mean over +-15 keyframes
loc=[]
for i in range(n):
    w=[rows[j][1] for j in range(max(0,i-15),min(n,i+16))]
    loc.append(rows[i][1]-sum(w)/len(w))
print("heading err high-pass (+-15 kf) rms %.3f deg" % ((sum(x*x for x in loc)/n)**.5))
step=max(1,n//24)
print(" t     posaz  dHead  dPosAz radial_cm dz_cm dPitch dRoll")
for r in rows[::step]:
    print(f"{r[0]:5.1f} {r[5]:7.1f} {r[1]:+6.3f} {r[2]:+6.3f} {r[3]:+6.2f} {r[4]:+6.2f} {r[6]:+6.3f} {r[7]:+6.3f}")
