#!/usr/bin/env python3
"""Builds the style-transfer test fixtures of panoconv (fixtures/style/).

Everything here is deterministic (fixed numpy seed, formula images, zlib level 9 with a fixed
PNG filter choice), so running it twice gives byte-identical files.

Outputs (all small, committed):
  generator.onnx          tiny CycleGAN-shaped ResNet generator, dynamic N/H/W axes
  generator_64.onnx       the same weights with a static 1x3x64x64 input (exercises tiling)
  pointwise.onnx          per-pixel model (1x1 conv + tanh), dynamic axes
  pointwise_64.onnx       the same, static 1x3x64x64: tiled must equal whole-image exactly
  bad_not_onnx.onnx       not an ONNX model at all
  bad_one_channel.onnx    [N,1,H,W] -> [N,1,H,W]
  bad_rank3.onnx          [3,H,W] -> [3,H,W]
  bad_shape.onnx          [1,3,64,64] -> [1,3,32,32]
  input_WxH.png           synthetic formula images (1242x375 and 1224x370)
  expected_WxH.png        onnxruntime outputs of generator.onnx on them, under the convention
                          below
  manifest.json           sizes, sha256 sums and tool versions, for the record

The convention (the same as panoconv::style):
  RGB8 -> float32 NCHW, x / 127.5 - 1; pad bottom/right by reflection to a multiple of 4;
  run; crop back to the original size; v = (y + 1) * 127.5 (float32); clip to [0, 255];
  round half away from zero; uint8.

Usage (from the repository root):
  python3 -m venv .venv && .venv/bin/pip install onnx numpy onnxruntime==1.31.1
  .venv/bin/python scripts/make_style_model.py [--out fixtures/style]
"""

import argparse
import hashlib
import json
import os
import struct
import zlib

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

OPSET = 17
SEED = 20240917
NGF = 8  # channels after the first conv; the two downsamplings go to 16 and 16
N_RES = 2


# ---------------------------------------------------------------------------------------------
# The generator
# ---------------------------------------------------------------------------------------------


class Builder:
    def __init__(self, rng):
        self.rng = rng
        self.nodes = []
        self.inits = []
        self.n = 0

    def name(self, base):
        self.n += 1
        return f"{base}_{self.n}"

    def const(self, base, arr):
        name = self.name(base)
        self.inits.append(numpy_helper.from_array(arr, name))
        return name

    def node(self, op, inputs, **attrs):
        out = self.name(op.lower())
        self.nodes.append(helper.make_node(op, inputs, [out], name=out + "_node", **attrs))
        return out

    def reflect_pad(self, x, p):
        pads = self.const("pads", np.array([0, 0, p, p, 0, 0, p, p], dtype=np.int64))
        return self.node("Pad", [x, pads], mode="reflect")

    def conv(self, x, cin, cout, k, stride=1, pad=0, gain=np.sqrt(2.0)):
        std = gain / np.sqrt(cin * k * k)
        w = self.const("w", (self.rng.standard_normal((cout, cin, k, k)) * std).astype(np.float32))
        b = self.const("b", (self.rng.standard_normal(cout) * 0.05).astype(np.float32))
        return self.node(
            "Conv", [x, w, b], kernel_shape=[k, k], strides=[stride, stride], pads=[pad] * 4
        )

    def conv_t(self, x, cin, cout, k=3):
        # Random channel mixing times a bilinear 3x3 kernel: with stride 2 this is exact linear
        # interpolation, so random weights give no checkerboard (and the PNGs stay small).
        assert k == 3
        mix = self.rng.standard_normal((cin, cout)) * np.sqrt(2.0 / cin)
        bil = np.outer([0.5, 1.0, 0.5], [0.5, 1.0, 0.5])
        w = self.const("wt", (mix[:, :, None, None] * bil).astype(np.float32))
        b = self.const("bt", (self.rng.standard_normal(cout) * 0.05).astype(np.float32))
        return self.node(
            "ConvTranspose",
            [x, w, b],
            kernel_shape=[k, k],
            strides=[2, 2],
            pads=[1, 1, 1, 1],
            output_padding=[1, 1],
        )

    def inorm(self, x, c):
        s = self.const("in_scale", (1.0 + 0.1 * self.rng.standard_normal(c)).astype(np.float32))
        b = self.const("in_bias", (0.1 * self.rng.standard_normal(c)).astype(np.float32))
        return self.node("InstanceNormalization", [x, s, b], epsilon=1e-5)

    def relu(self, x):
        return self.node("Relu", [x])


def generator_graph(in_shape, out_shape, name):
    """CycleGAN ResNet generator, miniature: c7s1-8, d16, d16, R16 x2, u16, u8, c7s1-3, tanh."""
    b = Builder(np.random.default_rng(SEED))
    c1, c2, c3 = NGF, 2 * NGF, 2 * NGF
    x = b.reflect_pad("input", 3)
    x = b.relu(b.inorm(b.conv(x, 3, c1, 7), c1))
    x = b.relu(b.inorm(b.conv(x, c1, c2, 3, stride=2, pad=1), c2))
    x = b.relu(b.inorm(b.conv(x, c2, c3, 3, stride=2, pad=1), c3))
    for _ in range(N_RES):
        y = b.relu(b.inorm(b.conv(b.reflect_pad(x, 1), c3, c3, 3), c3))
        y = b.inorm(b.conv(b.reflect_pad(y, 1), c3, c3, 3), c3)
        x = b.node("Add", [x, y])
    x = b.relu(b.inorm(b.conv_t(x, c3, c2), c2))
    x = b.relu(b.inorm(b.conv_t(x, c2, c1), c1))
    x = b.conv(b.reflect_pad(x, 3), c1, 3, 7, gain=1.6)
    # Final Tanh writes the graph output directly.
    b.nodes.append(helper.make_node("Tanh", [x], ["output"], name="tanh_out"))
    graph = helper.make_graph(
        b.nodes,
        name,
        [helper.make_tensor_value_info("input", TensorProto.FLOAT, in_shape)],
        [helper.make_tensor_value_info("output", TensorProto.FLOAT, out_shape)],
        b.inits,
    )
    return graph


def make_model(graph):
    model = helper.make_model(
        graph,
        opset_imports=[helper.make_opsetid("", OPSET)],
        producer_name="panoconv/scripts/make_style_model.py",
        producer_version="1",
    )
    model.ir_version = 8
    onnx.checker.check_model(model, full_check=True)
    return model


def identity_model(in_shape, out_shape, name):
    nodes = [helper.make_node("Identity", ["input"], ["output"])]
    graph = helper.make_graph(
        nodes,
        name,
        [helper.make_tensor_value_info("input", TensorProto.FLOAT, in_shape)],
        [helper.make_tensor_value_info("output", TensorProto.FLOAT, out_shape)],
    )
    return make_model(graph)


def pointwise_model(shape, name):
    """A 1x1 conv mixing the channels, then tanh: every output pixel depends on its input pixel
    only, so tiling must reproduce the whole-image run exactly (tests the tiling machinery)."""
    mix = np.array([[0.2, -1.1, 0.4], [0.9, 0.3, -0.5], [-0.6, 0.5, 1.2]], dtype=np.float32)
    w = numpy_helper.from_array(mix.reshape(3, 3, 1, 1), "w")
    b = numpy_helper.from_array(np.array([0.1, -0.2, 0.05], dtype=np.float32), "b")
    nodes = [
        helper.make_node("Conv", ["input", "w", "b"], ["mixed"], kernel_shape=[1, 1]),
        helper.make_node("Tanh", ["mixed"], ["output"]),
    ]
    graph = helper.make_graph(
        nodes,
        name,
        [helper.make_tensor_value_info("input", TensorProto.FLOAT, shape)],
        [helper.make_tensor_value_info("output", TensorProto.FLOAT, shape)],
        [w, b],
    )
    return make_model(graph)


def shape_model():
    nodes = [
        helper.make_node("AveragePool", ["input"], ["output"], kernel_shape=[2, 2], strides=[2, 2])
    ]
    graph = helper.make_graph(
        nodes,
        "bad_shape",
        [helper.make_tensor_value_info("input", TensorProto.FLOAT, [1, 3, 64, 64])],
        [helper.make_tensor_value_info("output", TensorProto.FLOAT, [1, 3, 32, 32])],
    )
    return make_model(graph)


# ---------------------------------------------------------------------------------------------
# Images
# ---------------------------------------------------------------------------------------------


def formula_image(w, h):
    """A smooth, colourful, deterministic test image with a few hard edges."""
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    r = 127.5 + 80 * np.sin(x / 41 + 0.7 * np.sin(y / 23)) + 40 * np.cos((x + y) / 97)
    g = 127.5 + 100 * np.sin(y / 29 + x / 180) * np.cos(x / 67)
    d = np.hypot(x - 0.3 * w, y - 0.6 * h)
    bl = 127.5 + 110 * np.sin(d / 19)
    img = np.stack([r, g, bl], axis=-1)
    # Two flat rectangles (hard edges, like a car and a sign).
    img[int(0.55 * h) : int(0.8 * h), int(0.6 * w) : int(0.75 * w)] = [200, 30, 40]
    img[int(0.1 * h) : int(0.25 * h), int(0.1 * w) : int(0.16 * w)] = [20, 60, 230]
    return np.clip(np.floor(img + 0.5), 0, 255).astype(np.uint8)


def _png_filter_rows(img):
    """Adaptive (min sum of abs) PNG filtering, vectorised; returns the raw zlib payload."""
    h, w, c = img.shape
    a = img.reshape(h, w * c).astype(np.int16)
    left = np.zeros_like(a)
    left[:, c:] = a[:, :-c]
    up = np.zeros_like(a)
    up[1:] = a[:-1]
    upleft = np.zeros_like(a)
    upleft[1:, c:] = a[:-1, :-c]
    p = left + up - upleft
    pa, pb, pc = np.abs(p - left), np.abs(p - up), np.abs(p - upleft)
    paeth = np.where((pa <= pb) & (pa <= pc), left, np.where(pb <= pc, up, upleft))
    cands = [a, a - left, a - up, a - ((left + up) >> 1), a - paeth]
    cands = [(cnd & 0xFF).astype(np.uint8) for cnd in cands]
    score = np.stack([np.abs(cnd.astype(np.int8).astype(np.int32)).sum(axis=1) for cnd in cands])
    best = score.argmin(axis=0)
    out = bytearray()
    for row in range(h):
        out.append(int(best[row]))
        out += cands[best[row]][row].tobytes()
    return bytes(out)


def write_png(path, img):
    h, w, _ = img.shape

    def chunk(tag, data):
        body = tag + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    raw = _png_filter_rows(img)
    data = b"\x89PNG\r\n\x1a\n"
    data += chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    data += chunk(b"IDAT", zlib.compress(raw, 9))
    data += chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(data)


# ---------------------------------------------------------------------------------------------
# Reference pass (the convention)
# ---------------------------------------------------------------------------------------------


def to_tensor(img):
    x = img.astype(np.float32).transpose(2, 0, 1)[None]
    return x / np.float32(127.5) - np.float32(1.0)


def from_tensor(y):
    v = (y[0].transpose(1, 2, 0) + np.float32(1.0)) * np.float32(127.5)
    v = np.clip(v, np.float32(0), np.float32(255))
    # Round half away from zero (v >= 0 here): exact in float32, unlike floor(v + 0.5).
    f = np.floor(v)
    return (f + (v - f >= np.float32(0.5))).astype(np.uint8)


def stylize_reference(sess, img):
    h, w, _ = img.shape
    ph, pw = (-h) % 4, (-w) % 4
    x = to_tensor(img)
    x = np.pad(x, ((0, 0), (0, 0), (0, ph), (0, pw)), mode="reflect")
    (y,) = sess.run(["output"], {"input": x})
    assert y.shape == x.shape, (y.shape, x.shape)
    return from_tensor(y[:, :, :h, :w])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument("--out", default=os.path.join(here, "..", "fixtures", "style"))
    args = ap.parse_args()
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)

    def save(model, name):
        onnx.save_model(model, os.path.join(out, name))

    dyn = ["N", 3, "H", "W"]
    save(make_model(generator_graph(dyn, dyn, "panoconv_tiny_cyclegan")), "generator.onnx")
    fixed = [1, 3, 64, 64]
    save(make_model(generator_graph(fixed, fixed, "panoconv_tiny_cyclegan_64")), "generator_64.onnx")
    save(pointwise_model(dyn, "pointwise"), "pointwise.onnx")
    save(pointwise_model(fixed, "pointwise_64"), "pointwise_64.onnx")
    save(identity_model(["N", 1, "H", "W"], ["N", 1, "H", "W"], "bad_one_channel"), "bad_one_channel.onnx")
    save(identity_model([3, "H", "W"], [3, "H", "W"], "bad_rank3"), "bad_rank3.onnx")
    save(shape_model(), "bad_shape.onnx")
    with open(os.path.join(out, "bad_not_onnx.onnx"), "wb") as f:
        f.write(b"this file is not an ONNX model, it is a test fixture of panoconv\n")

    import onnxruntime as ort

    so = ort.SessionOptions()
    so.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    sess = ort.InferenceSession(
        os.path.join(out, "generator.onnx"), so, providers=["CPUExecutionProvider"]
    )
    cases = []
    for w, h in [(1242, 375), (1224, 370)]:
        img = formula_image(w, h)
        res = stylize_reference(sess, img)
        write_png(os.path.join(out, f"input_{w}x{h}.png"), img)
        write_png(os.path.join(out, f"expected_{w}x{h}.png"), res)
        cases.append({"width": w, "height": h, "input": f"input_{w}x{h}.png",
                      "expected": f"expected_{w}x{h}.png",
                      "expected_mean": [float(m) for m in res.reshape(-1, 3).mean(axis=0)]})

    files = sorted(f for f in os.listdir(out) if f != "manifest.json")
    manifest = {
        "generator": "scripts/make_style_model.py",
        "onnxruntime": ort.__version__,
        "onnx": onnx.__version__,
        "numpy": np.__version__,
        "seed": SEED,
        "opset": OPSET,
        "convention": "cyclegan: x/127.5-1 in, (y+1)*127.5 out (clip, round half away), "
        "reflect pad bottom/right to multiple of 4, crop",
        "cases": cases,
        "sha256": {
            f: hashlib.sha256(open(os.path.join(out, f), "rb").read()).hexdigest() for f in files
        },
        "bytes": {f: os.path.getsize(os.path.join(out, f)) for f in files},
    }
    with open(os.path.join(out, "manifest.json"), "w") as f:
        json.dump(manifest, f, indent=2, sort_keys=True)
        f.write("\n")
    for f in files:
        print(f"{os.path.getsize(os.path.join(out, f)):>9}  {f}")


if __name__ == "__main__":
    main()
