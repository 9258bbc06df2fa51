"""rep53: `process --report` and `report --json` of a tree, for a same-bytes check against another's.
Usage: PYTHONPATH=TREE same_bytes.py OUTDIR FILE...   (each FILE: process -> NAME.gcode, .json, .html;
report NAME.gcode -> NAME.r.html, NAME.r.json; run both trees into the same OUTDIR path, moving
it away between, then `same_bytes.py --compare DIR_A DIR_B`)."""
import json
import os
import sys


def run(out, files):
    from gcode_opt import cli
    os.makedirs(out, exist_ok=True)
    for f in files:
        name = os.path.join(out, os.path.basename(f).rsplit(".", 1)[0])
        rc = cli.main(["process", f, "-o", name + ".gcode", "--json", name + ".json", "-q", "--report", name + ".html"])
        rc2 = cli.main(["report", f, name + ".gcode", "-o", name + ".r.html", "--json", name + ".r.json"]) \
            if os.path.exists(name + ".html") else None
        print(f, rc, rc2, flush=True)


def compare(a, b):
    bad = 0
    names = sorted(set(os.listdir(a)) | set(os.listdir(b)))
    for n in names:
        pa, pb = os.path.join(a, n), os.path.join(b, n)
        if not (os.path.exists(pa) and os.path.exists(pb)):
            print("missing", n)
            bad += 1
            continue
        da, db = open(pa, "rb").read(), open(pb, "rb").read()
        if n.endswith(".json") and not n.endswith(".r.json"):
            ja, jb = json.loads(da), json.loads(db)
            for j in (ja, jb):
                for k in ("timing_s", "elapsed_s", "output"):
                    j.pop(k, None)
            same = ja == jb
        else:
            same = da == db
        if not same:
            print("DIFFERENT", n)
            bad += 1
    print(f"{len(names)} files, {bad} different")
    return bad


if __name__ == "__main__":
    if sys.argv[1] == "--compare":
        sys.exit(1 if compare(sys.argv[2], sys.argv[3]) else 0)
    run(sys.argv[1], sys.argv[2:])
