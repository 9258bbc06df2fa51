"""HTML report (issue 3): placeholder until the report lands."""


def write_report(orig_path, new_path, profile, summary, html_path):
    raise NotImplementedError("the HTML report is not built yet")
