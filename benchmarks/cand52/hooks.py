"""cand52's measuring hooks (trace.py, rss_points.py): point(label) called around a step."""
from gcode_opt import plan


def wrap(owner, name, point, label, before=True, after_label=None, static=False):
    """owner.name replaced by a call of point("before " + label) (if before), the step,
    then point(after_label or label)."""
    f = getattr(owner, name)

    def g(*a, **k):
        if before:
            point("before " + label)
        r = f(*a, **k)
        point(after_label or label)
        return r
    setattr(owner, name, staticmethod(g) if static else g)


def wrap_of_pieces(point):
    """Candidates.of_pieces (a classmethod) between points "before of_pieces" and "after of_pieces"."""
    f = plan.Candidates.of_pieces.__func__

    def of_pieces(cls, *a, **k):
        point("before of_pieces")
        r = f(cls, *a, **k)
        point("after of_pieces")
        return r
    plan.Candidates.of_pieces = classmethod(of_pieces)
