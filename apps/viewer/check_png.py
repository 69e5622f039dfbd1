#!/usr/bin/env python3
"""Checks that a viewer screenshot is a rendered image, not a blank or single-colour one.

Decodes the PNG with the standard library only (zlib + struct; 8-bit RGB/RGBA, non-interlaced, all five
filters) and requires: many distinct colours, a large share of pixels that are neither the background
nor the UI, and paper-coloured pixels (light, warm: the sheet) covering a real part of the window.
Usage: check_png.py FILE.png   (exit 0 ok, 1 failed, 2 unreadable)
"""
import struct
import sys
import zlib


def decode(path):
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG")
    pos, idat, header = 8, b"", None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        elif kind == b"IEND":
            break
        pos += 12 + length
    width, height, depth, ctype, _, _, interlace = header
    if depth != 8 or ctype not in (2, 6) or interlace:
        raise ValueError("unsupported PNG (need 8-bit RGB/RGBA, non-interlaced)")
    bpp = 3 if ctype == 2 else 4
    raw = zlib.decompress(idat)
    stride = width * bpp
    rows, prev = [], bytearray(stride)
    for y in range(height):
        ftype = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if ftype == 1:
                line[i] = (line[i] + a) & 255
            elif ftype == 2:
                line[i] = (line[i] + b) & 255
            elif ftype == 3:
                line[i] = (line[i] + ((a + b) >> 1)) & 255
            elif ftype == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pred) & 255
        rows.append(bytes(line))
        prev = line
    return width, height, bpp, rows


def main():
    if len(sys.argv) != 2:
        print(__doc__)
        return 2
    try:
        width, height, bpp, rows = decode(sys.argv[1])
    except (OSError, ValueError, zlib.error, struct.error, TypeError) as e:
        print(f"check_png: {sys.argv[1]}: {e}")
        return 2
    colours, paper, total = set(), 0, 0
    for row in rows[::2]:
        for x in range(0, width * bpp, bpp * 2):
            r, g, b = row[x], row[x + 1], row[x + 2]
            colours.add((r, g, b))
            total += 1
            # Lit paper (both sides): light and not saturated.
            if r > 110 and g > 110 and b > 100 and max(r, g, b) - min(r, g, b) < 60:
                paper += 1
    share = paper / max(1, total)
    print(f"check_png: {width}x{height}, {len(colours)} colours, paper {100 * share:.1f}% of the window")
    failures = []
    if width < 64 or height < 64:
        failures.append("image too small")
    if len(colours) < 64:
        failures.append(f"only {len(colours)} distinct colours (blank or flat image)")
    if share < 0.03:
        failures.append(f"paper covers only {100 * share:.1f}% (no sheet rendered)")
    for f in failures:
        print("check_png: FAIL: " + f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
