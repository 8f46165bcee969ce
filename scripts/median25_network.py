"""Write and check the 5 x 5 median selection network of src/emva/spatial/histogram.rs.

Batcher's odd-even merge sort of 32 inputs; inputs 25..31 are +inf, so compare-exchanges
with them are resolved statically (a wire relabelled, or nothing); then only those the 13th
smallest (wire 12) depends on are kept. Checked on 20,000 random boxes with ties against a
sort, and printed as the Rust constant `NET`. Run: python3 scripts/median25_network.py
"""
import random, itertools
def batcher(n):
    ops=[]
    p=1
    while p<n:
        k=p
        while k>=1:
            for j in range(k%p, n-k, 2*k):
                for i in range(0, min(k, n-j-k)):
                    if (i+j)//(p*2) == (i+j+k)//(p*2):
                        ops.append((i+j, i+j+k))
            k//=2
        p*=2
    return ops
N=32; REAL=25; K=12
ops=batcher(N)
# sanity: sorts
for _ in range(200):
    v=[random.random() for _ in range(N)]
    for a,b in ops:
        if v[a]>v[b]: v[a],v[b]=v[b],v[a]
    assert v==sorted(v)
INF=None
phys=[w if w<REAL else INF for w in range(N)]
emitted=[]
for a,b in ops:
    pa,pb=phys[a],phys[b]
    if pa is INF and pb is INF: continue
    if pb is INF: continue  # min=a's value stays at a, max=inf at b
    if pa is INF:
        phys[a],phys[b]=pb,INF; continue
    emitted.append((pa,pb))
out=phys[K]
needed={out}
kept=[]
for a,b in reversed(emitted):
    if a in needed or b in needed:
        kept.append((a,b)); needed|={a,b}
kept.reverse()
print(len(ops), len(emitted), len(kept), "out", out)
# verify with ties
for _ in range(20000):
    v=[random.randint(0,6) if random.random()<0.5 else random.random()*6 for _ in range(REAL)]
    w=list(v)
    for a,b in kept:
        x,y=w[a],w[b]
        w[a]= x if x<y else y
        w[b]= y if x<y else x
    assert w[out]==sorted(v)[K], (w[out], sorted(v)[K])
print("ok")
print("const NET: [(u8, u8); %d] = [" % len(kept))
line="    "
for a,b in kept:
    t="(%d, %d), "%(a,b)
    if len(line)+len(t)>96: print(line.rstrip()); line="    "
    line+=t
print(line.rstrip()); print("];"); print("const OUT:", out)
