#!/usr/bin/env python3
"""Displacement profiles across the edge, real against simulated taps (issue 30).

    git apply docs/sim2real-edge2d/field-probe.patch && cargo build --release
    TACSIM_EDGE_PROBE=1 target/release/tacsim calibrate --real ../shared/data/real-tactip-edge2d --sensor SENSOR --edge square --edge-contact 45,0 -o DIR/x.toml --report DIR   (DIR new: the probe appends)
    python3 docs/sim2real-edge2d/field_profile.py DIR          # profiles by depth and lateral band
    python3 docs/sim2real-edge2d/field_profile.py DIR NAME     # one line: mean field error, far-side pull

The probe (edge preset label map) writes DIR/probe.csv and DIR/fields.csv: every tap's tracked
real and simulated pin displacements (px). Pins are turned into the edge frame (u towards the
material) by the yaw label; the second form averages d_u and d_v per 12 px cell, lateral band
and depth band and prints the mean |real - simulated| and, on taps off the material, the mean
real minus simulated d_u of the pins on the far side (positive: real pins move towards the
contact more).
"""
import csv,math,statistics as st,sys
from collections import defaultdict
taps={int(float(r['k'])):{k:float(v) for k,v in r.items()} for r in csv.DictReader(open(sys.argv[1]+'/probe.csv'))}
F=defaultdict(list)
for line in open(sys.argv[1]+'/fields.csv'):
    k,qx,qy,rx,ry,sx,sy=line.split(','); F[int(k)].append(tuple(map(float,(qx,qy,rx,ry,sx,sy))))
cx,cy=64.4,64.5
# angle of sim-weighted centroid
pts=[]
for k,t in taps.items():
    if t['lateral']<1 or t['depth']<4: continue
    wx=sum(math.hypot(f[4],f[5])*(f[0]-cx) for f in F[k]); wy=sum(math.hypot(f[4],f[5])*(f[1]-cy) for f in F[k])
    pts.append((t['yaw'],math.degrees(math.atan2(wy,wx))))
s,c=-1,93.0  # fitted once on the sim-weighted centroids: sign -1, offset 93 deg
if len(sys.argv) > 2:
    def prof(sel):
        bins=defaultdict(lambda:[[],[],[],[]])
        for k in sel:
            t=taps[k]; phi=math.radians(s*t['yaw']+c); co,si=math.cos(-phi),math.sin(-phi)
            for qx,qy,rx,ry,sx,sy in F[k]:
                u=(qx-cx)*co-(qy-cy)*si; v=(qx-cx)*si+(qy-cy)*co
                b=(int(math.floor(u/12)),int(math.floor(v/12)))
                bins[b][0].append(rx*co-ry*si); bins[b][1].append(sx*co-sy*si)
                bins[b][2].append(rx*si+ry*co); bins[b][3].append(sx*si+sy*co)
        return bins
    tot=[];far=[];cnt=0
    for zl,zh in [(3.0,3.6),(3.6,4.3),(4.3,5.01)]:
      for lo in [-6,-4,-2,0,2,4]:
        sel=[k for k,t in taps.items() if lo<=t['lateral']<lo+2 and zl<=t['depth']<zh]
        if len(sel)<10: continue
        B=prof(sel)
        for b,v in B.items():
            if len(v[0])<20: continue
            e=math.hypot(st.mean(v[0])-st.mean(v[1]), st.mean(v[2])-st.mean(v[3]))
            tot.append(e)
            if b[0]<=-2 and lo<=-2: far.append(st.mean(v[0])-st.mean(v[1]))
    print(f"{sys.argv[2]}: mean field error {st.mean(tot):.3f} px over {len(tot)} cells; far side (off-material taps) real-sim d_u {st.mean(far):+.3f}")
    sys.exit(0)
def prof(sel,label):
    bins=defaultdict(lambda:[[],[],[],[]])
    for k in sel:
        t=taps[k]; phi=math.radians(s*t['yaw']+c); co,si=math.cos(-phi),math.sin(-phi)
        for qx,qy,rx,ry,sx,sy in F[k]:
            u=(qx-cx)*co-(qy-cy)*si; v=(qx-cx)*si+(qy-cy)*co
            if abs(v)>20: continue
            b=int(math.floor(u/8))
            bins[b][0].append(rx*co-ry*si); bins[b][1].append(sx*co-sy*si)
            bins[b][2].append(rx*si+ry*co); bins[b][3].append(sx*si+sy*co)
    print(label, f"n={len(sel)}   (u px bins toward material: real d_u / sim d_u)")
    print("   "+" ".join(f"{8*b:+4d}:{st.mean(bins[b][0]):+.2f}/{st.mean(bins[b][1]):+.2f}" for b in sorted(bins) if -6<=b<=5))
for zl,zh in [(4.3,5.01),(3.6,4.3)]:
  for lo in [-5,-3,-1,1,3]:
    sel=[k for k,t in taps.items() if lo<=t['lateral']<lo+2 and zl<=t['depth']<zh]
    prof(sel,f"z{zl}-{zh} lab y {lo}..{lo+2}")
