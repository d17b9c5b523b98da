"""Adds up firmware/tools/pcprof.c's per-PC counts per function (arm-none-eabi-nm symbols).
usage: pcprof_report.py PROF.txt ELF [INTERVALS]   (counts are divided by INTERVALS)"""
import sys, subprocess, bisect, collections
elf=sys.argv[2]
syms=[]
for line in subprocess.run(['arm-none-eabi-nm','-n','-C','--defined-only',elf],capture_output=True,text=True).stdout.splitlines():
    p=line.split(' ',2)
    if len(p)<3 or p[1] not in 'tTwW': continue
    syms.append((int(p[0],16)&~1,p[2]))
syms.sort(); addrs=[a for a,_ in syms]
tot=collections.Counter(); allc=0
for line in open(sys.argv[1]):
    if line.startswith('intervals'): print(line.strip()); continue
    pc,c=line.split(); pc=int(pc,16); c=int(c); allc+=c
    i=bisect.bisect_right(addrs,pc)-1
    tot[syms[i][1] if i>=0 else '?']+=c
n=int(sys.argv[3]) if len(sys.argv)>3 else 1
print('total %.2f M (per pair %.3f M)'%(allc/1e6, allc/n/1e6))
for name,c in tot.most_common(40): print('%8.1f k/pair %5.1f%%  %s'%(c/n/1e3,100*c/allc,name[:110]))
