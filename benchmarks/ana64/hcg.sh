#!/bin/bash
# (the harness is benchmarks/ana64/harness.py; HFUNCS=module:func,module:Class.method wraps those with dumps too;
#  the helper /tmp/crv62_libcgt.so: gcc -O1 -shared -fPIC -o /tmp/crv62_libcgt.so benchmarks/crv62/cgt.c)
# hcg.sh TREE FILE TAG: the harness's replay under callgrind, instructions per step
D=$(dirname "$(realpath "$0")"); TREE=$(cd "$1" && pwd); F=$(realpath "$2"); TAG=$3
rm -rf /tmp/cg/$TAG.d; mkdir -p /tmp/cg/$TAG.d
cd "$TREE" && HFUNCS=$HFUNCS HARNESS_CG=1 PYTHONHASHSEED=1 PYTHONPATH=$TREE valgrind --tool=callgrind --collect-atstart=no --dump-instr=no --callgrind-out-file=/tmp/cg/$TAG.d/cg.out \
    /tmp/venv/bin/python $D/harness.py "$F" > /tmp/cg/$TAG.log 2>&1
grep "batches\|digest" /tmp/cg/$TAG.log
/tmp/venv/bin/python - /tmp/cg/$TAG.d <<'PY'
import sys, glob, re, collections
c = collections.Counter(); n = collections.Counter()
for f in glob.glob(sys.argv[1] + '/cg.out*'):
    lab = tot = None
    with open(f) as fh:
        for line in fh:
            if line.startswith('desc: Trigger:'):
                m = re.search(r'Client Request: (\S+)', line); lab = m.group(1) if m else line.strip()
            elif line.startswith('totals:') or line.startswith('summary:'):
                tot = int(line.split()[1])
    c[lab] += tot or 0; n[lab] += 1
T = sum(c.values())
for k, v in c.most_common(): print(f'{v/1e6:10.1f} M  dumps {n[k]:5d}  {k}')
print(f'{T/1e6:10.1f} M total')
PY
