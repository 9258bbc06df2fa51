"""MeatPack, the G-code encoding of binary G-code blocks (encodings 1 and 2).

MeatPack packs two characters of a small alphabet into one byte, 4 bits each (low nibble
first): 0-9 . space \\n G X, with 'E' in place of the space once "no spaces" is on (the
G-code words are then written without spaces).  A nibble 1111 means "the character is
not in the alphabet: it follows as a whole byte".  0xFF 0xFF CMD switches modes (251
packing on, 250 off, 247/246 no-spaces on/off, 249 reset).

The encoding is lossy the way libbgcode (PrusaSlicer's writer) makes it, and decode()
gives the text libbgcode's reader gives:
  * a line starting with ';' is kept verbatim (encoding 2) or dropped (encoding 1);
  * other lines lose their comment and surrounding blanks; empty lines are dropped;
  * a line holding a G word ('G' then a digit) loses its spaces and has e/x/g upper-cased;
    the reader puts a space back before every parameter letter of a line starting with G.
    (libbgcode also rewrites a '*' line checksum, into a form its own reader cannot give
    back; slicers write none, and here such a line is packed as it is, so that it too
    decodes to itself.)
So decode(encode(decode(x))) == decode(x): the text a printer runs is a fixed point, and
gcode-opt works on the decoded text.  (Empty lines collapse inside a block; only a block's
first line may be empty: bgcode.py starts a new block at each empty line.)  Written from the MeatPack description and libbgcode's
documented behaviour (github.com/prusa3d/libbgcode), with its own implementation.
"""
from __future__ import annotations

import re

import numpy as np

SIGNAL = 0xFF
CMD_ENABLE_PACKING = 251
CMD_DISABLE_PACKING = 250
CMD_RESET_ALL = 249
CMD_QUERY_CONFIG = 248
CMD_ENABLE_NO_SPACES = 247
CMD_DISABLE_NO_SPACES = 246

_ALPHABET = b"0123456789. \nGX"          # nibble value -> character (15 = "not packed")
_NL = 12                                  # nibble of '\n'
_SPACE = 11                               # nibble of ' ' ('E' with no-spaces on)
G_PARAMS = b"XYZEFIJRSGPWHCA"             # letters the reader spaces out in a G line


def _char(nibble, nospace):
    if nibble == _SPACE and nospace:
        return b"E"
    return _ALPHABET[nibble:nibble + 1]


# ----------------------------------------------------------------------------- decode
def _nibble_chars(shift, nospace):
    return np.frombuffer(b"".join(_char((b >> shift) & 0xF, nospace) if (b >> shift) & 0xF != 0xF else b"?"
                                  for b in range(256)), dtype=np.uint8)


_LO_CHAR = {ns: _nibble_chars(0, ns) for ns in (False, True)}
_HI_CHAR = {ns: _nibble_chars(4, ns) for ns in (False, True)}
_KEEP_HI = np.array([(b & 0xF) != _NL for b in range(256)])          # after a '\n' the high nibble is padding
_MARKER = np.array([(b & 0xF) == 0xF or ((b >> 4) == 0xF and (b & 0xF) != _NL) for b in range(256)])
_N_RAW = [(1 if (b & 0xF) == 0xF else 0) + (1 if (b >> 4) == 0xF and (b & 0xF) != _NL else 0)
          for b in range(256)]
_NEWLINES = re.compile(rb"\n\n+")
_PARAM_SPACE = re.compile(rb"(?<=[^ \n])(?=[" + G_PARAMS + rb"])")


def _split_commands(data: bytes):
    """[(False, data bytes) | (True, command byte)] as the reader sees them: two 0xFF in a
    row make the next other byte a command; a lone 0xFF is data."""
    out = []
    start = 0
    pos = data.find(b"\xff")
    n = len(data)
    while pos >= 0:
        if pos > start:
            out.append((False, data[start:pos]))
        count, active, k = 0, False, pos
        while k < n:                         # run the reader's signal logic over this stretch
            c = data[k]
            k += 1
            if c == SIGNAL:
                if count > 0:
                    active, count = True, 0
                else:
                    count += 1
                continue
            if active:
                out.append((True, c))
                active = False
                if count == 0:
                    break
                continue
            if count > 0:
                out.append((False, b"\xff" + bytes([c])))
                count = 0
            else:
                out.append((False, bytes([c])))
            break
        start = k
        pos = data.find(b"\xff", start)
    if start < n:
        out.append((False, data[start:]))
    return out


class _Unpacker:
    def __init__(self):
        self.packing = False
        self.nospace = False
        self.queue = 0           # whole characters still to come
        self.held = b""          # a packed character that follows the next whole one
        self.out = []

    def command(self, c):
        if c == CMD_ENABLE_PACKING:
            self.packing = True
        elif c in (CMD_DISABLE_PACKING, CMD_RESET_ALL):
            self.packing = False
        elif c == CMD_ENABLE_NO_SPACES:
            self.nospace = True
        elif c == CMD_DISABLE_NO_SPACES:
            self.nospace = False

    def data(self, chunk: bytes):
        if not self.packing:
            self.out.append(chunk)
            return
        k = 0
        while k < len(chunk) and (self.queue or self.held):      # finish a token split by a command
            self._slow(chunk[k])
            k += 1
        if k >= len(chunk):
            return
        buf = np.frombuffer(chunk, dtype=np.uint8)[k:]
        # Which bytes stand for themselves is sequential (a whole byte may look like a
        # marker): walk the few marker candidates, then expand everything at once.
        cand = np.flatnonzero(_MARKER[buf]).tolist()
        n_raw_of = _N_RAW
        kinds, marks = [], []
        nxt = 0                       # first byte not yet consumed as a whole character
        cut = len(buf)
        for p in cand:
            if p < nxt:
                continue
            r = n_raw_of[buf[p]]
            if p + r >= len(buf):     # its whole characters come in the next chunk
                cut = p
                break
            marks.append(p)
            kinds.append(r)
            nxt = p + r + 1
        nospace = self.nospace
        lo_c, hi_c, keep_hi = _LO_CHAR[nospace], _HI_CHAR[nospace], _KEEP_HI
        b = buf[:cut]
        out = np.empty((len(b), 2), dtype=np.uint8)
        out[:, 0] = lo_c[b]
        out[:, 1] = hi_c[b]
        keep = np.empty((len(b), 2), dtype=bool)
        keep[:, 0] = True
        keep[:, 1] = keep_hi[b]
        if marks:
            m = np.asarray(marks, dtype=np.int64)
            mb = b[m]
            lo_full = (mb & 0xF) == 0xF
            hi_full = (mb >> 4) == 0xF
            # marker slots: the low char unless it is whole; never the high slot
            keep[m, 0] = ~lo_full
            keep[m, 1] = False
            r1 = m + 1                                 # the first whole character
            out[r1, 0] = b[r1]
            keep[r1, 0] = True
            lo_only = lo_full & ~hi_full               # high char comes after the whole one
            out[r1[lo_only], 1] = hi_c[mb[lo_only]]
            keep[r1, 1] = lo_only
            both = lo_full & hi_full
            r2 = m[both] + 2
            out[r2, 0] = b[r2]
            keep[r2, 0] = True
            keep[r2, 1] = False
        self.out.append(out[keep].tobytes())
        for c in chunk[k + cut:]:
            self._slow(c)

    def _slow(self, c):
        if self.queue:
            self.out.append(bytes([c]) + self.held)
            self.held = b""
            self.queue -= 1
            return
        lo, hi = c & 0xF, c >> 4
        if lo == 0xF:
            self.queue += 1
            if hi == 0xF:
                self.queue += 1
            else:
                self.held = _char(hi, self.nospace)
        else:
            ch = _char(lo, self.nospace)
            self.out.append(ch)
            if ch != b"\n":
                if hi == 0xF:
                    self.queue += 1
                else:
                    self.out.append(_char(hi, self.nospace))


def decode(data: bytes) -> bytes:
    """The G-code text a MeatPack block holds, as libbgcode's reader writes it."""
    u = _Unpacker()
    for is_cmd, v in _split_commands(bytes(data)):
        if is_cmd:
            u.command(v)
        else:
            u.data(v)
    text = _NEWLINES.sub(b"\n", b"".join(u.out))
    # the reader spaces out the words of lines starting with G: done on those lines at once
    lines = text.split(b"\n")
    g_lines = [ln for ln in lines if ln[:1] == b"G"]
    if not g_lines:
        return text
    spaced = iter(_PARAM_SPACE.sub(b" ", b"\n".join(g_lines)).split(b"\n"))
    return b"\n".join([next(spaced) if ln[:1] == b"G" else ln for ln in lines])


# ----------------------------------------------------------------------------- encode
_PACKABLE = np.zeros(256, dtype=bool)
_VALUE = np.full(256, 0xF, dtype=np.uint8)
for _v, _c in enumerate(_ALPHABET):
    if _c != ord(" "):
        _PACKABLE[_c] = True
        _VALUE[_c] = _v
_PACKABLE[ord("E")] = True                # no-spaces mode: E takes the space's code
_VALUE[ord("E")] = _SPACE
_DIGITS = b"0123456789"
_UPPER = bytes.maketrans(b"exg", b"EXG")


def _line_text(line: bytes, keep_comments: bool):
    """What one line becomes before packing: (raw, text) - raw lines are copied as they are;
    None when the line is dropped."""
    if not line:
        return None
    if line[:1] == b";":
        return (True, line) if keep_comments else None
    if line[:1] == b"\n" or len(line) < 2:       # (libbgcode also drops a line starting with '\r',
        return None                               # which its reader can give: kept here)
    semi = line.find(b";")
    body = (line if semi < 0 else line[:semi]).strip(b" \t")
    if not body:
        return None
    g = body.find(b"G")
    if 0 <= g < len(body) - 1 and body[g + 1] in _DIGITS:       # the first G starts a G word
        body = body.translate(_UPPER, b" ") + b"\n"
    if not body.endswith(b"\n"):
        body += b"\n"
    return (False, body)


def _pack(texts):
    """Pack lines (each ending in '\\n') two characters to a byte; returns one bytes per line."""
    padded = [t + b"\n" if len(t) % 2 else t for t in texts]     # an odd line pairs its '\n' with '\n'
    buf = np.frombuffer(b"".join(padded), dtype=np.uint8)
    c1, c2 = buf[0::2], buf[1::2]
    p1, p2 = _PACKABLE[c1], _PACKABLE[c2]
    v1, v2 = _VALUE[c1], _VALUE[c2]
    packed = (v2 << 4) | v1                     # a non-packable side's nibble is 1111
    size = np.where(p1 & p2, 1, np.where(p1 | p2, 2, 3))
    end = np.cumsum(size)
    out = np.zeros(int(end[-1]) if len(end) else 0, dtype=np.uint8)
    first = end - size
    out[first] = packed
    one_raw = p1 ^ p2                           # the whole character follows
    out[first[one_raw] + 1] = np.where(p1, c2, c1)[one_raw]
    both = ~(p1 | p2)
    out[first[both] + 1] = c1[both]
    out[first[both] + 2] = c2[both]
    lens = np.fromiter((len(t) // 2 for t in padded), dtype=np.int64, count=len(padded))
    pair_end = np.cumsum(lens)
    byte_end = end[pair_end - 1] if len(pair_end) else pair_end
    byte_start = np.concatenate([[0], byte_end[:-1]])
    blob = out.tobytes()
    return [blob[s:e] for s, e in zip(byte_start.tolist(), byte_end.tolist())]


def _cmd(c):
    return bytes([SIGNAL, SIGNAL, c])


def encode(text: bytes, keep_comments: bool = True) -> bytes:
    """One block's G-code text -> MeatPack bytes (encoding 2 with keep_comments, else 1)."""
    parts = bytes(text).split(b"\n")           # lines end at '\n' only, as libbgcode splits them
    lines = [p + b"\n" for p in parts[:-1]] + ([parts[-1]] if parts[-1] else [])
    items = [x for x in (_line_text(ln, keep_comments) for ln in lines) if x is not None]
    if text[:1] == b"\n":                        # the reader gives a block's leading empty line
        items.insert(0, (False, b"\n"))
    packed = iter(_pack([t for raw, t in items if not raw]))
    out = [_cmd(CMD_ENABLE_PACKING), _cmd(CMD_ENABLE_NO_SPACES)]
    packing = True
    for raw, t in items:
        if raw:
            if packing:
                out.append(_cmd(CMD_DISABLE_PACKING))
                packing = False
            out.append(t)
        else:
            if not packing:
                out.append(_cmd(CMD_ENABLE_PACKING))
                packing = True
            out.append(next(packed))
    if not keep_comments:
        out.append(_cmd(CMD_RESET_ALL))
    return b"".join(out)
