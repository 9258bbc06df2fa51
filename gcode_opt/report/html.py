"""The self-contained HTML report (plots embedded as base64 PNG; opens offline).

Every number the page shows sits in an element carrying ``data-key`` (its path in the
report JSON, e.g. ``headline.print_time_s.after``), ``data-unit`` and ``data-value`` (the
JSON value, full precision), so a test -- or a curious user -- can check the page against
the JSON."""
from __future__ import annotations

import base64
import html as _h
import json
import os

from .. import __version__
from .data import build_report
from .fmt import fmt

CSS = """
body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,sans-serif;margin:24px auto;max-width:1250px;
color:#222;padding:0 16px;line-height:1.4}
h1{font-size:1.6em;margin-bottom:0}h2{border-bottom:2px solid #ddd;padding-bottom:4px;margin-top:36px}
.sub{color:#666;margin-top:4px}
table{border-collapse:collapse;margin:10px 0}th,td{padding:4px 10px;border-bottom:1px solid #e4e4e4;text-align:left}
th{background:#f4f4f4}td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
td.good{color:#1a7f37}td.bad{color:#b42318}
.warn{background:#fff4e5;border-left:5px solid #f59e0b;padding:8px 12px;margin:6px 0}
.warn.warning{background:#fdecea;border-left-color:#d93025}
.ok{background:#e8f5e9;border-left:5px solid #2e7d32;padding:8px 12px}
img{max-width:100%;border:1px solid #eee;margin:6px 0}
.note{color:#555;font-size:.92em}.small{font-size:.85em;color:#666}
.kpi{display:inline-block;margin:8px 24px 8px 0}.kpi b{font-size:1.5em;display:block}
"""

# (label, json key under headline, unit code, note)
HEADLINE_ROWS = [
    ("Print time, whole file", "print_time_s", "s", "firmware model"),
    ("Time of the re-timed strokes", "retimed_time_s", "s", ""),
    ("∫|a|² dt, re-timed strokes", "int_a2_retimed_mm2_s3", "mm2_s3", "the inertia norm the law lowers"),
    ("∫|a|² dt, whole file", "int_a2_whole_mm2_s3", "mm2_s3", "includes direction changes on curves"),
    ("Ringing RMS, whole file (XY)", "ringing_rms_um", "um", "what shows on the print as ghosting: see Ringing"),
    ("Peak ringing, whole file (XY)", "ringing_peak_um", "um", ""),
    ("Kinetic-energy integral m/2 ∫|v|² dt, re-timed strokes", "kinetic_retimed_J_s", "J_s",
     "m = the profile's moving mass along each stroke"),
    ("Kinetic-energy integral m/2 ∫|v|² dt, whole file", "kinetic_whole_J_s", "J_s", ""),
    ("J = m/2 ∫|v|² dt + α m²/2 ∫|a|² dt, re-timed strokes", "J_retimed_J_s", "J_s",
     "each stroke at the β = αm it was optimised for"),
    ("Peak speed, whole file", "peak_speed_mm_s", "mm_s", ""),
    ("Peak acceleration, whole file", "peak_accel_mm_s2", "mm_s2", "tangential or at a junction"),
    ("Peak speed, re-timed strokes", "peak_speed_retimed_mm_s", "mm_s", ""),
    ("Peak acceleration, re-timed strokes", "peak_accel_retimed_mm_s2", "mm_s2", ""),
    ("Corners (turns > 30°)", "corners", "count", ""),
    ("Σ dv² at corners", "corner_dv2_mm2_s2", "mm2_s2", "velocity jumps the firmware takes at corners"),
    ("Full stops", "full_stops", "count", "junctions slower than 0.5 mm/s"),
    ("Segments shorter than the firmware's minimum segment time", "short_segments", "count", ""),
    ("File size", "file.bytes", "bytes", ""),
    ("Line count", "file.lines", "count", ""),
]


def _get(data, path):
    cur = data
    for p in path.split("."):
        cur = cur[int(p)] if isinstance(cur, list) else cur[p]
    return cur


def _cell(data, key, unit, cls="num"):
    v = _get(data, key)
    extra = ""
    if unit == "pct" and v is not None:
        extra = " good" if v < 0 else (" bad" if v > 0 else "")
    return (f'<td class="{cls}{extra}" data-key="{key}" data-unit="{unit}" data-value="{_h.escape(json.dumps(v))}">'
            f"{_h.escape(fmt(v, unit))}</td>")


def _img(png, alt):
    return f'<img alt="{_h.escape(alt)}" src="data:image/png;base64,{base64.b64encode(png).decode()}">'


def _headline_html(data):
    h = data["headline"]
    out = ['<table><tr><th>Quantity</th><th>Before</th><th>After</th><th>Change</th><th>Note</th></tr>']
    for label, key, unit, note in HEADLINE_ROWS:
        if key.startswith("ringing_") and key not in h:     # run without the ringing figures
            continue
        if _get(h, key) is None:
            out.append(f"<tr><td>{_h.escape(label)}</td><td colspan=3 class=note>n/a</td>"
                       f"<td class=note>{_h.escape(note or 'needs a finite β: not known for these strokes')}</td></tr>")
            continue
        k = f"headline.{key}"
        n = note
        extra = ""
        law = _get(h, key).get("law")
        if law is not None:
            extra = f'law as planned: <span data-key="{k}.law" data-unit="{unit}" data-value="{json.dumps(law)}">' \
                    f"{_h.escape(fmt(law, unit))}</span>"
        if key == "J_retimed_J_s":
            n = f"{note} ({h[key]['strokes']} strokes with a finite β)"
        note_html = "; ".join(x for x in (_h.escape(n), extra) if x)
        out.append(f"<tr><td>{_h.escape(label)}</td>{_cell(data, k + '.before', unit)}"
                   f"{_cell(data, k + '.after', unit)}{_cell(data, k + '.change', 'pct')}"
                   f"<td class=note>{note_html}</td></tr>")
    out.append("</table>")
    return "\n".join(out)


def _kpis(data):
    h = data["headline"]
    # the whole file leads (issue 9): its change, and how much of it was re-timed
    items = [("∫|a|² dt whole file", "headline.int_a2_whole_mm2_s3.change", "pct"),
             ("print time", "headline.print_time_s.change", "pct"),
             ("of the file's ∫|a|² dt re-timed", "coverage.retimed.int_a2_share", "share"),
             ("of its print time re-timed", "coverage.retimed.time_share", "share"),
             ("∫|a|² dt on re-timed strokes", "headline.int_a2_retimed_mm2_s3.change", "pct"),
             ("strokes re-timed", "headline.strokes.retimed", "count")]
    if "ringing_rms_um" in h:
        items.insert(2, ("ringing RMS (frame resonance)", "headline.ringing_rms_um.change", "pct"))
    out = []
    for label, key, unit in items:
        v = _get(data, key)
        out.append(f'<div class="kpi"><b data-key="{key}" data-unit="{unit}" data-value="{json.dumps(v)}">'
                   f"{_h.escape(fmt(v, unit))}</b>{_h.escape(label)}</div>")
    del h
    return "".join(out)


def _share_txt(v):
    return fmt(v, "share")


def _share_td(key, v):
    if "." in key.split(".", 2)[-1]:          # a reason with a dot cannot be a data-key path
        return f'<td class="num">{_share_txt(v)}</td>'
    return (f'<td class="num" data-key="{_h.escape(key)}" data-unit="share" data-value="{json.dumps(v)}">'
            f"{_share_txt(v)}</td>")


def _coverage_html(data):
    """What was re-timed and what was left, and why: the report's lead."""
    c = data.get("coverage")
    if not c:
        return ""
    rt = c["retimed"]
    out = [f"<p>Re-timed: {rt['strokes']:,} strokes holding <b>{_share_txt(rt['int_a2_share'])}</b> of the "
           f"original file's ∫|a|² dt and <b>{_share_txt(rt['time_share'])}</b> of its print time.</p>"]
    fi = c.get("features") or {}
    if fi.get("why") or fi.get("note"):
        out.append(f"<p class=note>Features: {_h.escape(fi.get('why') or fi.get('note'))}</p>")
    by_reason = c.get("left_by_reason")
    if by_reason:
        out.append("<table><tr><th>Left as sliced, because</th><th>Count</th><th>Share of ∫|a|² dt</th>"
                   "<th>Share of print time</th></tr>")
        for why, g in by_reason.items():
            k = f"coverage.left_by_reason.{why}"
            count = f"{g['count']:,} {g['unit']}" if g.get("count") else ""
            out.append(f"<tr><td>{_h.escape(why)}</td><td class=num>{_h.escape(count)}</td>"
                       f"{_share_td(k + '.int_a2_share', g.get('int_a2_share'))}"
                       f"{_share_td(k + '.time_share', g.get('time_share'))}</tr>")
        out.append("</table>")
    left = c.get("left_by_feature") or []
    if left:
        out.append("<table><tr><th>Not re-timed, by feature</th><th>Moves</th><th>Share of ∫|a|² dt</th>"
                   "<th>Share of print time</th></tr>")
        for i, g in enumerate(left):
            sel = {True: " (selected)", False: " (not selected)"}.get(g.get("selected"), "")
            k = f"coverage.left_by_feature.{i}"
            out.append(f"<tr><td>{_h.escape(g['feature'] + sel)}</td><td class=num>{g['moves']:,}</td>"
                       f"{_share_td(k + '.int_a2_share', g['int_a2_share'])}"
                       f"{_share_td(k + '.time_share', g['time_share'])}</tr>")
        out.append("</table>")
    return "".join(out)


def _strokes_html(data):
    s = data["headline"]["strokes"]
    parts = [f'<p>Re-timed: <b data-key="headline.strokes.retimed" data-unit="count" '
             f'data-value="{s["retimed"]}">{s["retimed"]:,}</b>']
    if s.get("candidates") is not None:
        parts.append(f' of <span data-key="headline.strokes.candidates" data-unit="count" '
                     f'data-value="{s["candidates"]}">{s["candidates"]:,}</span> candidate strokes.')
    else:
        parts.append(" strokes (the candidates and the reasons for skipping need the pipeline's summary: "
                     "run <code>gcode-opt process … --report</code>).")
    parts.append("</p>")
    nr = s.get("not_retimed")
    if nr:
        parts.append("<table><tr><th>Not re-timed because</th><th>Strokes</th></tr>")
        for reason, n in sorted(nr.items(), key=lambda kv: -kv[1]):
            key = f"headline.strokes.not_retimed.{reason}"
            parts.append(f'<tr><td>{_h.escape(reason)}</td><td class="num" data-key="{_h.escape(key)}" '
                         f'data-unit="count" data-value="{n}">{n:,}</td></tr>')
        parts.append("</table>")
    elif nr is not None:
        parts.append("<p class=note>Every candidate stroke was re-timed.</p>")
    return "".join(parts)


def _group_html(data, name, label):
    rows = data[name]
    out = [f"<table><tr><th>{label}</th><th>Strokes</th><th>Length</th><th>Time before</th><th>Time after</th>"
           "<th>Change</th><th>∫|a|² dt before</th><th>∫|a|² dt after</th><th>Change</th></tr>"]
    key1 = {"by_feature": "feature", "by_layer": "layer", "by_kind": "kind"}[name]
    for i, g in enumerate(rows):
        p = f"{name}.{i}"
        out.append(f"<tr><td>{_h.escape(str(g[key1]))}</td>{_cell(data, p + '.strokes', 'count')}"
                   f"{_cell(data, p + '.length_mm', 'mm')}"
                   f"{_cell(data, p + '.time_s.before', 's')}{_cell(data, p + '.time_s.after', 's')}"
                   f"{_cell(data, p + '.time_s.change', 'pct')}"
                   f"{_cell(data, p + '.int_a2_mm2_s3.before', 'mm2_s3')}"
                   f"{_cell(data, p + '.int_a2_mm2_s3.after', 'mm2_s3')}"
                   f"{_cell(data, p + '.int_a2_mm2_s3.change', 'pct')}</tr>")
    out.append("</table>")
    return "\n".join(out)


RINGING_ROWS = [("RMS", "rms_um"), ("peak", "peak_um"), ("RMS excited by the ramps", "rms_ramp_um"),
                ("RMS excited by the corners", "rms_corner_um"),
                ("RMS excited by the gentle turns", "rms_turn_um")]


def _ringing_html(data, plot_png):
    """Ringing before/after per axis and for the XY vector, its parts, the shaper's
    smoothing, and the stretch plot."""
    r = data.get("ringing")
    if not r:
        return ""
    m = r["model"]
    shaper = "no input shaper" if m["shaper"] == "none" else \
        f"the {m['shaper'].upper()} input shaper tuned at {m['shaper_freq_x_hz']:g} / {m['shaper_freq_y_hz']:g} Hz"
    out = [f"<p class=note>Each axis modelled as a damped oscillator (resonance {m['freq_x_hz']:g} Hz X, "
           f"{m['freq_y_hz']:g} Hz Y, damping ratio {m['damping_r']:g}: the profile's [resonance] table) driven "
           f"by the motion the firmware model commands, with {_h.escape(shaper)}; ringing = the toolhead's "
           "error minus its quasi-static lag, solved exactly. RMS over the print time, peak over the whole "
           "file. Ramps: the trapezoids' acceleration steps; corners: velocity jumps at turns over 30° and "
           "into/out of rest; gentle turns: vertices of curves cut into segments.</p>",
           "<table><tr><th>Ringing</th><th>Axis</th><th>Before</th><th>After</th><th>Change</th></tr>"]
    for label, key in RINGING_ROWS:
        for ax, axis_label in (("", "XY"), ("x.", "X"), ("y.", "Y")):
            k = f"ringing.headline.{ax}{key}"
            out.append(f"<tr><td>{_h.escape(label)}</td><td>{axis_label}</td>{_cell(data, k + '.before', 'um')}"
                       f"{_cell(data, k + '.after', 'um')}{_cell(data, k + '.change', 'pct')}</tr>")
    for key, label in (("smoothing_rms_um", "shaper smoothing, RMS"), ("smoothing_max_um", "shaper smoothing, max")):
        if key in r["headline"]:
            k = f"ringing.headline.{key}"
            out.append(f"<tr><td>{label}</td><td>XY</td>{_cell(data, k + '.before', 'um')}"
                       f"{_cell(data, k + '.after', 'um')}<td></td></tr>")
    out.append("</table>")
    st = r["stretch"]
    out.append(f"<p class=note>The plot: the {st['length_mm']:g} mm of path from {st['from_mm']:.1f} mm where "
               "the original rings most; both files over the same path distances (the path is unchanged).</p>")
    if plot_png is not None:
        out.append(_img(plot_png, "ringing along the stretch where the original rings most"))
    return "\n".join(out)


def _warnings_html(data):
    ws = data["warnings"]
    if not ws:
        return '<div class="ok">Nothing to warn about: no stroke stretched beyond the budget, segment rates ' \
               'well below the firmware\'s limit, no speed above the slicer\'s F.</div>'
    out = []
    for w in ws:
        lines = ""
        if w.get("lines"):
            more = " …" if (w.get("count") or 0) > len(w["lines"]) else ""
            lines = f'<br><span class="small">original lines: {", ".join(map(str, w["lines"]))}{more}</span>'
        out.append(f'<div class="warn {w["level"]}"><b>{w["level"]}</b> [{w["code"]}]: '
                   f'{_h.escape(w["message"])}{lines}</div>')
    return "\n".join(out)


def render_html(data, ctx) -> str:
    from . import plots, profiles
    h = data["headline"]
    body = [f"<h1>gcode-opt report</h1><p class=sub>{_h.escape(os.path.basename(data['original']))} → "
            f"{_h.escape(os.path.basename(data['processed']))} · profile <b>{_h.escape(data['profile'])}</b> "
            f"({_h.escape(data['flavour'])}) · moving mass X {data['mass_kg']['x']:g} kg, "
            f"Y {data['mass_kg']['y']:g} kg · gcode-opt {__version__}</p>",
            _kpis(data),
            "<h2>The whole file: what was re-timed, what was left and why</h2>", _coverage_html(data),
            "<h2>Warnings</h2>", _warnings_html(data),
            "<h2>Headline</h2>",
            "<p class=note>All figures come from the firmware model (constant-acceleration lookahead planner "
            "of the profile) playing the original and the processed file. Change = after/before − 1.</p>",
            _headline_html(data), "<h3>Strokes</h3>", _strokes_html(data)]
    if data.get("ringing"):
        from .ringing import ringing_plot
        body += ["<h2>Ringing</h2>", _ringing_html(data, ringing_plot(data["ringing"]))]
    body += [
            "<h2>Per feature type and per layer</h2>",
            _img(plots.reduction_chart(data), "int a^2 before and after per feature and per layer"),
            "<h3>Per feature type</h3>", _group_html(data, "by_feature", "Feature"),
            "<h3>Per layer</h3>", _group_html(data, "by_layer", "Layer"),
            "<h3>Per path kind</h3>", _group_html(data, "by_kind", "Kind"),
            "<h2>Speed and acceleration of representative strokes</h2>",
            "<p class=note>Red: the original file's trapezoids as the firmware plans them (phase by phase). "
            "Blue: the processed file as the firmware executes its segments. Green dashed: the optimal law "
            "itself. Acceleration is tangential (along the path).</p>"]
    for rep in data["representative"]:
        sc = profiles.stroke_curves(rep, data, ctx)
        if sc is None:
            body.append(f"<p><b>{_h.escape(rep['role'])}</b>: {_h.escape(rep['note'])}.</p>")
            continue
        body.append(f"<h3>{_h.escape(sc['title'])}</h3>")
        if sc["note"]:
            body.append(f"<p class=note>{_h.escape(sc['note'])}.</p>")
        body.append(_img(plots.stroke_chart(sc), sc["title"]))
    lm = data["layer_map"]
    body += [f"<h2>Layer {lm['layer']} from above</h2>",
             f"<p class=note>Layer {lm['layer']} (z = {lm['z_mm'] if lm['z_mm'] is not None else 'n/a'} mm), "
             f"chosen as the layer where re-timing removed the most ∫|a|² dt; {lm['retimed_strokes']} re-timed "
             f"strokes, ∫|a|² dt {_h.escape(fmt(lm['int_a2_retimed_mm2_s3']['before'], 'mm2_s3'))} → "
             f"{_h.escape(fmt(lm['int_a2_retimed_mm2_s3']['after'], 'mm2_s3'))}.</p>",
             _img(plots.layer_map(ctx, lm["layer"]), f"layer {lm['layer']} coloured by acceleration"),
             "<h2>About these numbers</h2>",
             "<p class=note>∫|a|² dt is in mm²/s³ (1 m²/s³ = 10⁶ mm²/s³); energies in J·s. The per-stroke figures "
             "pair every fenced block of the processed file (<code>; gcode-opt begin … end</code>) with the "
             "original lines it replaced. The same figures, and one row per re-timed stroke, are in the JSON "
             "(<code>gcode-opt report ORIGINAL PROCESSED --json REPORT.json</code>).</p>"]
    del h
    return ("<!DOCTYPE html>\n<html lang=en><head><meta charset=utf-8>"
            "<meta name=viewport content='width=device-width, initial-scale=1'>"
            f"<title>gcode-opt report: {_h.escape(os.path.basename(data['original']))}</title>"
            f"<style>{CSS}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n")


def write_report(orig_path, new_path, profile, summary, html_path, json_path=None, layer=None, ringing=True):
    """Build the report of orig_path -> new_path; write HTML (and JSON if json_path).
    Returns the report dict.  ringing=False leaves the ringing section out."""
    data, ctx = build_report(orig_path, new_path, profile, summary, layer, ringing)
    if summary is not None and summary.get("output"):
        data["processed"] = summary["output"]       # the path the user will find it at
    text = render_html(data, ctx)
    with open(html_path, "w", encoding="utf-8") as fh:
        fh.write(text)
    if json_path:
        write_json(data, json_path)
    return data


def write_json(data, path):
    with open(path, "w", encoding="utf-8") as fh:
        json.dump(data, fh, indent=1, allow_nan=False, default=_json_default)


def _json_default(o):
    import numpy as np
    from .stroke_table import RowStream, StrokeTable
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, StrokeTable):            # the per-stroke rows, made as written
        return RowStream(o)
    raise TypeError(f"not JSON serialisable: {type(o)}")
