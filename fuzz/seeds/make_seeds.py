#!/usr/bin/env python3
"""Writes the fuzz targets' seed corpora (fuzz/corpus/<target>/seed-*):
the shipped files and, for structure-aware mutation, valid inputs with one
field made extreme (0, negative, 1e30, NaN, a huge count, a truncated line,
a wrong unit). Run from the repository root; libFuzzer mutates from there."""
import glob, os, re

EXTREMES = ["0", "-1", "-0", "1e30", "-1e30", "1e-30", "nan", "NaN", "inf", "-inf",
            "4294967296", "18446744073709551616", "1e309", "", "x", "1,5"]

def write(target, name, data):
    d = os.path.join("fuzz", "corpus", target)
    os.makedirs(d, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(d, "seed-" + name), "wb") as f:
        f.write(data)

# .lens: the shipped prescriptions, the broken test file, and each numeric
# field of each table row and header made extreme in turn.
lenses = sorted(glob.glob("crates/optica_optics/lenses/*.lens")) + ["tests/assets/lenses/broken.lens"]
for path in lenses:
    text = open(path, encoding="utf-8").read()
    stem = os.path.splitext(os.path.basename(path))[0]
    write("lens", stem, text)
    lines = text.splitlines()
    write("lens", stem + "-truncated", "\n".join(lines)[: len(text) // 2])
    write("lens", stem + "-mm-to-m", text.replace("units = mm", "units = m"))
    for i, line in enumerate(lines):
        if line.lstrip().startswith("#") or not line.strip():
            continue
        fields = line.split()
        for j, f in enumerate(fields):
            if not re.match(r"^-?[0-9.]+(/[0-9.]+)?$", f):
                continue
            for k, e in enumerate(EXTREMES[:10]):
                mutated = list(lines)
                mutated[i] = " ".join(fields[:j] + [e] + fields[j + 1 :])
                write("lens", f"{stem}-l{i}f{j}-{k}", "\n".join(mutated) + "\n")
    # Many copies of one row: more surfaces than a lens may have.
    rows = [l for l in lines if l.strip() and not l.lstrip().startswith("#") and "=" not in l]
    header = [l for l in lines if "=" in l]
    write("lens", stem + "-many-rows", "\n".join(header + rows[:1] * 200 + rows[1:]) + "\n")

# Head-trace CSV: the columns HeadTrace writes, a few samples, and each
# value made extreme.
header = "t,head_x,head_y,head_z,qx,qy,qz,qw,ipd,gaze_x,gaze_y,gaze_z,valid"
rows = ["0.00,0,1.6,0,0,0,0,1,0.063,0,0,-1,1",
        "0.01,0.01,1.6,0,0,0.05,0,0.9987,0.063,0.1,0,-1,1",
        "0.02,0.02,1.61,0,0,0.1,0,0.995,0.063,,,,0"]
csv = "\n".join([header] + rows) + "\n"
write("head_trace", "basic", csv)
write("head_trace", "minimal", "t,head_x,head_y,head_z,qx,qy,qz,qw\n0,0,0,0,0,0,0,1\n")
write("head_trace", "eyes", "t,head_x,head_y,head_z,qx,qy,qz,qw,left_gaze_x,left_gaze_y,left_gaze_z,right_gaze_x,right_gaze_y,right_gaze_z\n0,0,1.6,0,0,0,0,1,0,0,-1,0,0,-1\n1,0,1.6,0,0,0,0,1,0.1,0,-1,0.1,0,-1\n")
write("head_trace", "header-only", header + "\n")
write("head_trace", "backwards", "\n".join([header, rows[1], rows[0]]) + "\n")
for r in range(3):
    cols = rows[r].split(",")
    for c in range(len(cols)):
        for k, e in enumerate(EXTREMES):
            mutated = list(cols)
            mutated[c] = e
            body = list(rows)
            body[r] = ",".join(mutated)
            write("head_trace", f"r{r}c{c}-{k}", "\n".join([header] + body) + "\n")

# DTrack datagrams: the documented shape, and each number made extreme.
good = ("fr 21753\nts 39596.024\n6dcal 1\n6d 1 [0 1.000][326.848 -187.216 -7.977 0.0000 0.0000 30.0000]"
        "[0.866025 0.500000 0.000000 -0.500000 0.866025 0.000000 0.000000 0.000000 1.000000]\n")
write("dtrack", "good", good)
write("dtrack", "two-bodies", "fr 5\n6d 2 [0 1][0 0 0 0 0 0][1 0 0 0 1 0 0 0 1] [3 0.5][100 200 300 0 0 0][0 1 0 -1 0 0 0 0 1]\n")
write("dtrack", "empty", "fr 1\n6d 0\n")
numbers = re.findall(r"-?[0-9]+\.?[0-9]*", good)
for n, num in enumerate(numbers):
    for k, e in enumerate(EXTREMES):
        parts = re.split(r"(-?[0-9]+\.?[0-9]*)", good)
        idx = 2 * n + 1
        if idx < len(parts):
            parts[idx] = e
            write("dtrack", f"n{n}-{k}", "".join(parts))
write("dtrack", "huge-count", "6d 1000000000 [0 1][0 0 0 0 0 0][1 0 0 0 1 0 0 0 1]\n")
write("dtrack", "zero-matrix", "6d 1 [0 1][0 0 0 0 0 0][0 0 0 0 0 0 0 0 0]\n")

# Frame ranges as a farm manager writes them.
for k, text in enumerate(["0..10", "5", "3..=7", "0..=0", "10..5", "7..7", "4294967295", "0..=4294967295",
                          "", "..", "..=", "a..b", " 1 .. 2 ", "-1..3", "99999999999", "1..2..3"]):
    write("frame_range", f"{k}", text)

# CAVE cluster datagrams: "OPCV", the version byte, then postcard (varint
# enum index and lengths, little-endian floats). Each message kind, a head
# with each number made extreme, truncations, another version.
import struct

def varint(n):
    out = bytearray()
    while True:
        b = n & 0x7F
        n >>= 7
        if n:
            out.append(b | 0x80)
        else:
            out.append(b)
            return bytes(out)

def text(s):
    b = s.encode()
    return varint(len(b)) + b

def head(floats, timestamp=0.5, valid=1, gaze=True, eye_gaze=False):
    # eyes [Vec3; 2], orientation Quat, gaze Option<Vec3>, eye_gaze Option<[Vec3; 2]>, timestamp f64, valid bool
    f = list(floats)
    out = struct.pack("<6f", *f[0:6]) + struct.pack("<4f", *f[6:10])
    out += (b"\x01" + struct.pack("<3f", *f[10:13])) if gaze else b"\x00"
    out += (b"\x01" + struct.pack("<6f", *f[13:19])) if eye_gaze else b"\x00"
    return out + struct.pack("<d", timestamp) + bytes([valid])

HEADER = b"OPCV\x01"
good_head = [-0.0315, 1.6, 0, 0.0315, 1.6, 0, 0, 0, 0, 1, 0, 0, -1, 0, 0, -1, 0, 0, -1]
sample = HEADER + varint(1) + varint(42) + head(good_head)
write("cave_datagram", "join", HEADER + varint(0) + text("front"))
write("cave_datagram", "sample", sample)
write("cave_datagram", "sample-eye-gaze", HEADER + varint(1) + varint(7) + head(good_head, eye_gaze=True))
write("cave_datagram", "drawn", HEADER + varint(2) + varint(42) + text("floor/left"))
write("cave_datagram", "end", HEADER + varint(3))
write("cave_datagram", "huge-n", HEADER + varint(1) + varint(2**64 - 1) + head(good_head))
write("cave_datagram", "long-name", HEADER + varint(0) + text("w" * 900))
write("cave_datagram", "huge-name-length", HEADER + varint(0) + varint(2**63) + b"front")
write("cave_datagram", "other-version", b"OPCV\x02" + sample[5:])
write("cave_datagram", "bad-variant", HEADER + varint(9))
for cut in range(5, len(sample), 7):
    write("cave_datagram", f"truncated-{cut}", sample[:cut])
for i in range(len(good_head)):
    for k, e in enumerate([0.0, -1.0, 1e30, float("nan"), float("inf"), -float("inf")]):
        f = list(good_head)
        f[i] = e
        write("cave_datagram", f"head{i}-{k}", HEADER + varint(1) + varint(1) + head(f, eye_gaze=True))
for k, t in enumerate([float("nan"), float("inf"), -1e300, 0.0]):
    write("cave_datagram", f"time-{k}", HEADER + varint(1) + varint(1) + head(good_head, timestamp=t))
write("cave_datagram", "valid-2", HEADER + varint(1) + varint(1) + head(good_head, valid=2))
