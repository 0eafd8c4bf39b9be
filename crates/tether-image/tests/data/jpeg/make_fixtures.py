#!/usr/bin/env python3
"""Writes the JPEG fixtures of tests/jpeg_decode.rs and OpenCV's grey decode of each.

Run from this directory with OpenCV 4.14, Pillow and jpegtran:
  pip install opencv-python-headless==4.14.0.94 numpy pillow
  apt-get install libjpeg-turbo-progs
  python3 make_fixtures.py
Each NAME.jpg gets NAME.cv2.gray: the raw bytes of cv2.imread(NAME.jpg,
cv2.IMREAD_GRAYSCALE | cv2.IMREAD_IGNORE_ORIENTATION), row by row, and the sizes go to
fixtures.txt. The picture is synthetic (gradients, discs, seeded noise).
"""
import random, struct
import cv2
import numpy as np
from PIL import Image

W, H = 61, 47

def picture():
    rng = np.random.default_rng(11)
    y, x = np.mgrid[0:H, 0:W].astype(np.float32)
    b = 40 + 3 * x
    g = 200 - 3 * y
    r = 128 + 90 * np.sin(x / 5) * np.cos(y / 7)
    img = np.stack([b, g, r], axis=-1)
    for cx, cy, rad, col in [(15, 12, 9, (255, 40, 40)), (44, 30, 12, (20, 220, 90))]:
        img[(x - cx) ** 2 + (y - cy) ** 2 < rad ** 2] = col
    img += rng.normal(0, 12, img.shape)
    return np.clip(img, 0, 255).astype(np.uint8)

# --- a minimal baseline writer, for sampling factors no common encoder writes -------
ZZ = [0, 1, 8, 16, 9, 2, 3, 10, 17, 24, 32, 25, 18, 11, 4, 5, 12, 19, 26, 33, 40, 48,
      41, 34, 27, 20, 13, 6, 7, 14, 21, 28, 35, 42, 49, 56, 57, 50, 43, 36, 29, 22, 15,
      23, 30, 37, 44, 51, 58, 59, 52, 45, 38, 31, 39, 46, 53, 60, 61, 54, 47, 55, 62, 63]
DC_BITS = [0, 1, 5, 1, 1, 1, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0]
AC_BITS = [0, 2, 1, 3, 3, 2, 4, 3, 5, 5, 4, 4, 0, 0, 1, 0x7d]
AC_VALS = bytes.fromhex(
    "01020300041105122131410613516107227114328191a1082342b1c11552d1f0243362728209"
    "0a161718191a25262728292a3435363738393a434445464748494a535455565758595a636465"
    "666768696a737475767778797a838485868788898a92939495969798999aa2a3a4a5a6a7a8a9"
    "aab2b3b4b5b6b7b8b9bac2c3c4c5c6c7c8c9cad2d3d4d5d6d7d8d9dae1e2e3e4e5e6e7e8e9ea"
    "f1f2f3f4f5f6f7f8f9fa")

def codes(bits, vals):
    out, code, k = {}, 0, 0
    for length in range(1, 17):
        for _ in range(bits[length - 1]):
            out[vals[k]] = (code, length)
            code += 1
            k += 1
        code <<= 1
    return out

def seg(marker, payload):
    return bytes([0xFF, marker]) + struct.pack(">H", len(payload) + 2) + payload

def write_baseline(w, h, comps, blocks, quant, app=b""):
    """comps: (id, h, v); blocks[ci][row][col]: 64 quantised coefficients, natural order."""
    out = bytearray(b"\xff\xd8") + app
    out += seg(0xDB, bytes([0]) + bytes(quant[ZZ[i]] for i in range(64)))
    out += seg(0xC0, struct.pack(">BHHB", 8, h, w, len(comps))
               + b"".join(bytes([c[0], (c[1] << 4) | c[2], 0]) for c in comps))
    out += seg(0xC4, bytes([0x00]) + bytes(DC_BITS) + bytes(range(12)))
    out += seg(0xC4, bytes([0x10]) + bytes(AC_BITS) + AC_VALS)
    out += seg(0xDA, bytes([len(comps)]) + b"".join(bytes([c[0], 0]) for c in comps) + bytes([0, 63, 0]))
    dcc, acc = codes(DC_BITS, list(range(12))), codes(AC_BITS, AC_VALS)
    bits = []
    def put(v, n):
        bits.extend((v >> i) & 1 for i in range(n - 1, -1, -1))
    def cat(v):
        return abs(v).bit_length()
    pred = [0] * len(comps)
    def encode(ci, blk):
        d = blk[0] - pred[ci]
        pred[ci] = blk[0]
        n = cat(d)
        put(*dcc[n])
        if n:
            put(d if d >= 0 else d + (1 << n) - 1, n)
        run = 0
        for k in range(1, 64):
            v = blk[ZZ[k]]
            if v == 0:
                run += 1
                continue
            while run > 15:
                put(*acc[0xF0])
                run -= 16
            n = cat(v)
            put(*acc[(run << 4) | n])
            put(v if v >= 0 else v + (1 << n) - 1, n)
            run = 0
        if run:
            put(*acc[0])
    hmax, vmax = max(c[1] for c in comps), max(c[2] for c in comps)
    for my in range(-(-h // (8 * vmax))):
        for mx in range(-(-w // (8 * hmax))):
            for ci, c in enumerate(comps):
                for yy in range(c[2]):
                    for xx in range(c[1]):
                        encode(ci, blocks[ci][my * c[2] + yy][mx * c[1] + xx])
    bits.extend([1] * (-len(bits) % 8))
    for i in range(0, len(bits), 8):
        byte = int("".join(map(str, bits[i:i + 8])), 2)
        out.append(byte)
        if byte == 0xFF:
            out.append(0)
    return bytes(out + b"\xff\xd9")

def luma_subsampled():
    """Y at 1x1 while Cb is 2x2: libjpeg upsamples the luma plane (h2v2 "fancy")."""
    rng = random.Random(5)
    comps = [(1, 1, 1), (2, 2, 2), (3, 1, 1)]
    mx, my = -(-W // 16), -(-H // 16)
    blocks = []
    for c in comps:
        rows = []
        for by in range(my * c[2]):
            row = []
            for bx in range(mx * c[1]):
                b = [0] * 64
                b[0] = int(40 * np.sin(bx / 2) + 30 * np.cos(by / 3)) + rng.randint(-5, 5)
                for k in range(1, rng.randint(2, 20)):
                    b[ZZ[k]] = rng.randint(-9, 9)
                row.append(b)
            rows.append(row)
        blocks.append(rows)
    quant = [rng.randint(2, 12) for _ in range(64)]
    jfif = seg(0xE0, b"JFIF\x00\x01\x01\x00\x00\x01\x00\x01\x00\x00")
    return write_baseline(W, H, comps, blocks, quant, app=jfif)

def main():
    img = picture()
    files = {}
    def cv(name, params, image=img):
        ok, buf = cv2.imencode(".jpg", image, params)
        assert ok
        files[name] = buf.tobytes()
    cv("baseline_420_rst2", [cv2.IMWRITE_JPEG_QUALITY, 75, cv2.IMWRITE_JPEG_RST_INTERVAL, 2])
    cv("progressive_420", [cv2.IMWRITE_JPEG_QUALITY, 90, cv2.IMWRITE_JPEG_PROGRESSIVE, 1])
    cv("progressive_grey_444", [cv2.IMWRITE_JPEG_PROGRESSIVE, 1],
       image=cv2.cvtColor(img, cv2.COLOR_BGR2GRAY))
    prog = files["progressive_420"]
    files["progressive_truncated"] = prog[: len(prog) * 3 // 5]
    # Cut inside the second scan: only DC is known, libjpeg-turbo interpolates the DC too.
    second_sos = prog.index(b"\xff\xda", prog.index(b"\xff\xda") + 2)
    files["progressive_dc_only"] = prog[: second_sos + 20]
    base = files["baseline_420_rst2"]
    files["baseline_truncated"] = base[: len(base) // 2]
    files["luma_subsampled"] = luma_subsampled()
    # Arithmetic coding: jpegtran (libjpeg-turbo-progs) re-codes the coefficients
    # losslessly; the decode must not change.
    import subprocess
    def arithmetic(src, *flags):
        return subprocess.run(["jpegtran", "-arithmetic", *flags], input=files[src],
                              capture_output=True, check=True).stdout
    files["arith_420_rst2"] = arithmetic("baseline_420_rst2")
    files["arith_progressive_420"] = arithmetic("progressive_420", "-progressive")
    arith_prog = files["arith_progressive_420"]
    files["arith_progressive_truncated"] = arith_prog[: len(arith_prog) * 3 // 5]
    from io import BytesIO
    rgb = Image.fromarray(cv2.cvtColor(img, cv2.COLOR_BGR2RGB))
    for name, im, kw in [("cmyk_adobe", rgb.convert("CMYK"), {}),
                         ("rgb_adobe", rgb, {"keep_rgb": True})]:
        bio = BytesIO()
        im.save(bio, "JPEG", quality=85, **kw)
        files[name] = bio.getvalue()
    sizes = []
    for name, data in files.items():
        with open(name + ".jpg", "wb") as f:
            f.write(data)
        g = cv2.imread(name + ".jpg", cv2.IMREAD_GRAYSCALE | cv2.IMREAD_IGNORE_ORIENTATION)
        assert g is not None, name
        with open(name + ".cv2.gray", "wb") as f:
            f.write(g.tobytes())
        sizes.append(f"{name} {g.shape[1]} {g.shape[0]}")
    with open("fixtures.txt", "w") as f:
        f.write("\n".join(sizes) + "\n")

if __name__ == "__main__":
    main()
