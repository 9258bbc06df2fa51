"""A file that cannot seek: the readers' joining paths (test_speed38_analyse_*)."""
import os
import threading


def through_fifo(tmp_path, text, read):
    """read(path) of a FIFO a thread writes text into (not seekable)."""
    path = str(tmp_path / "fifo.gcode")
    if os.path.exists(path):
        os.unlink(path)
    os.mkfifo(path)

    def write():
        with open(path, "wb") as fh:
            fh.write(text)
    th = threading.Thread(target=write)
    th.start()
    try:
        return read(path)
    finally:
        th.join()
