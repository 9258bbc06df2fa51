"""Fold py-spy's raw stacks (`py-spy record --native -f raw`) into the subtree of one function:
each child's share of all the samples, Python and C frames together, to a depth.

    GCODE_OPT_WINDOWED=1 py-spy record --native -r 997 -f raw -o rect1.txt -- \\
        python -m gcode_opt process plate_rectilinear.gcode -o out.gcode -q --profile prusa-mk3s
    python benchmarks/pyspy_tree.py "candidates_curve (" 8 0.3 rect1.txt [rect2.txt ...]

FUNC is matched as a substring of a frame ("name (file.py:line)", the line dropped); the
first frame of a stack that matches roots it.  Samples are time (wall, on one core), so
read the shares, not the counts, and take several runs: the machine is shared (round 50
picked its areas this way; callgrind then measured what each change saved)."""
import re
import sys


def _norm(frame):
    return re.sub(r":\d+\)", ")", frame).replace("gcode_opt/", "")


def fold(root, depth, files):
    tree, total = {}, 0
    for fn in files:
        with open(fn) as fh:
            for line in fh:
                line = line.rstrip()
                if not line:
                    continue
                stack, n = line.rsplit(" ", 1)
                n = int(n)
                total += n
                frames = [_norm(f) for f in stack.split(";")]
                at = next((k for k, f in enumerate(frames) if root in f), None)
                if at is None:
                    continue
                node = tree
                for f in frames[at:at + depth + 1]:
                    entry = node.setdefault(f, [0, {}])
                    entry[0] += n
                    node = entry[1]
    return tree, total


def show(node, total, min_pct, indent=0, out=sys.stdout):
    for name, (n, children) in sorted(node.items(), key=lambda kv: -kv[1][0]):
        if 100.0 * n / total < min_pct:
            continue
        out.write(f"{100.0 * n / total:6.2f} {'  ' * indent}{name[:110]}\n")
        show(children, total, min_pct, indent + 1, out)


if __name__ == "__main__":
    if len(sys.argv) < 5:
        sys.exit(__doc__)
    tree, total = fold(sys.argv[1], int(sys.argv[2]), sys.argv[4:])
    show(tree, max(total, 1), float(sys.argv[3]))
