"""cgself.py DIR LABEL [N]: self cost per function summed over dump files of LABEL."""
import sys, glob, re, collections
d, lab = sys.argv[1], sys.argv[2]; N = int(sys.argv[3]) if len(sys.argv) > 3 else 30
tot = collections.Counter()
def part(f):
    m = re.search(r'\.(\d+)$', f); return int(m.group(1)) if m else 10**9
names = {}
for f in sorted(glob.glob(d + '/cg.out*'), key=part):
    txt = open(f).read()
    m = re.search(r'Client Request: (\S+)', txt)
    want = bool(m and m.group(1) == lab)
    for mm in re.finditer(r'^c?fn=\((\d+)\) (.*)$', txt, re.M): names[mm.group(1)] = mm.group(2)
    if not want: continue
    fn = None; skip = False
    for line in txt.splitlines():
        if line.startswith('fn='):
            m2 = re.match(r'fn=\((\d+)\)(?: (.*))?', line)
            if m2:
                if m2.group(2): names[m2.group(1)] = m2.group(2)
                fn = names.get(m2.group(1))
            else: fn = line[3:]
            skip = False
        elif line.startswith('calls='): skip = True
        elif line and (line[0].isdigit() or line[0] in '+-*'):
            if skip: skip = False; continue
            parts = line.split()
            if len(parts) >= 2 and fn: tot[fn] += int(parts[1])
T = sum(tot.values())
print(f'{lab}: {T/1e6:.1f} M')
for k, v in tot.most_common(N): print(f'{v/1e6:9.2f} M  {k[:120]}')
