#!/usr/bin/env python3
"""Pin blob statistics of edge taps by depth band, real against simulated (no numpy needed).

    python3 docs/sim2real-edge2d/blob_stats.py real ../shared/data/real-tactip-edge2d
    python3 docs/sim2real-edge2d/blob_stats.py sim target/sim2real-edge2d/sim

Per depth-label band (the lab's pose_3, or the simulated set's pose_z through the recipe's
[rig]): blobs inside 48 px of the pin field's centre (64.4, 64.5), their mean area and the
white pixels there; every 4th real tap, every 12th simulated one.
"""
import csv, zlib, struct, sys
def read_png(path):
    data=open(path,'rb').read()
    pos=8; w=h=0; idat=b''; ct=0; bd=8
    while pos<len(data):
        ln=struct.unpack('>I',data[pos:pos+4])[0]; typ=data[pos+4:pos+8]; body=data[pos+8:pos+8+ln]
        if typ==b'IHDR': w,h,bd,ct=struct.unpack('>IIBB',body[:10])
        elif typ==b'IDAT': idat+=body
        pos+=12+ln
    raw=zlib.decompress(idat)
    bpp={0:1,2:3,4:2,6:4}[ct]
    if bd==1:
        stride=(w+7)//8; bpp=1
    else: stride=w*bpp
    rows=[]; prev=bytearray(stride); i=0
    for y in range(h):
        f=raw[i]; line=bytearray(raw[i+1:i+1+stride]); i+=1+stride
        for x in range(stride):
            a=line[x-bpp] if x>=bpp else 0; b=prev[x]; c=prev[x-bpp] if x>=bpp else 0
            if f==1: line[x]=(line[x]+a)&255
            elif f==2: line[x]=(line[x]+b)&255
            elif f==3: line[x]=(line[x]+(a+b)//2)&255
            elif f==4:
                p=a+b-c; pa=abs(p-a); pb=abs(p-b); pc=abs(p-c)
                pr=a if pa<=pb and pa<=pc else (b if pb<=pc else c)
                line[x]=(line[x]+pr)&255
        rows.append(line); prev=line
    if bd==1:
        return w,h,[[ (r[x//8]>>(7-x%8))&1 for x in range(w)] for r in rows]
    return w,h,[[1 if r[x*bpp]>127 else 0 for x in range(w)] for r in rows]
def stats(path, cx=64.4, cy=64.5, R=48):
    w,h,img=read_png(path)
    seen=set(); areas=[]
    for y in range(h):
        for x in range(w):
            if img[y][x] and (x,y) not in seen and (x-cx)**2+(y-cy)**2<R*R:
                st=[(x,y)]; seen.add((x,y)); n=0
                while st:
                    px,py=st.pop(); n+=1
                    for qx,qy in ((px+1,py),(px-1,py),(px,py+1),(px,py-1)):
                        if 0<=qx<w and 0<=qy<h and img[qy][qx] and (qx,qy) not in seen:
                            seen.add((qx,qy)); st.append((qx,qy))
                areas.append(n)
    return len(areas), sum(areas)/max(1,len(areas)), sum(areas)
which, d = sys.argv[1], sys.argv[2]
bands={}
if which=='real':
    for r in list(csv.DictReader(open(d+'/targets.csv')))[::4]:
        z=float(r['pose_3']); b=min(3,int((z-3)/0.5))
        bands.setdefault(b,[]).append(stats(d+'/images/'+r['sensor_image']))
else:
    for r in list(csv.DictReader(open(d+'/targets.csv')))[::12]:
        z=float(r['pose_z']); b=min(3,int((z-3)/0.5))
        bands.setdefault(b,[]).append(stats(d+'/images/'+r['sensor_image']))
for b in sorted(bands):
    v=bands[b]; n=len(v)
    print(which, f"depth {3+0.5*b:.1f}: blobs {sum(x[0] for x in v)/n:.1f} mean area {sum(x[1] for x in v)/n:.2f} white px {sum(x[2] for x in v)/n:.0f} (n {n})")
