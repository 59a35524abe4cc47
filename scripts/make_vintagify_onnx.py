#!/usr/bin/env python3
"""Turns a real trained CycleGAN generator into the ONNX model that `panoconv --style` runs,
without PyTorch.

The generator is vintagify's `G_A2B_epoch33.pth` (PyPI package `vintagify==0.1.2`, MIT): a
CycleGAN ResNet-9 generator (ngf 64, 11.4 M parameters) saved as a PyTorch state dict, which is
a zip holding a pickle (`data.pkl`) and one raw little-endian storage per tensor (`data/N`).
This script reads that zip with a restricted unpickler (it builds numpy arrays and refuses any
other global, so no code from the file runs), and writes the same network with `onnx.helper`:

    ReflectionPad(3) c7s1-64 IN ReLU | d128 d256 (3x3 stride 2, IN, ReLU)
    | 9 x [ReflectionPad(1) conv3 IN ReLU ReflectionPad(1) conv3 IN] + skip
    | u128 u64 (ConvTranspose 3x3 stride 2, pad 1, output_padding 1, IN, ReLU)
    | ReflectionPad(3) c7s1-3 Tanh

with InstanceNorm affine (epsilon 1e-5, no running statistics: PyTorch's default), input
`input` [N, 3, H, W] and output `output` of the same shape, dynamic N/H/W: panoconv's
convention (RGB8 -> x / 127.5 - 1, output (y + 1) * 127.5; docs/style.md).

The same recipe exports any CycleGAN ResNet generator saved as a state dict: the names of the
layers (`model.K.weight`, `model.K.block.J.weight`) are those of the reference implementation's
`ResnetGenerator` (junyanz/pytorch-CycleGAN-and-pix2pix uses the same Sequential layout, with
`InstanceNorm2d(affine=False)` by default: pass --no-affine-norm for those). With PyTorch at
hand, `torch.onnx.export(G, torch.zeros(1, 3, 256, 256), "g.onnx", input_names=["input"],
output_names=["output"], dynamic_axes={"input": {0: "n", 2: "h", 3: "w"}, "output": {0: "n",
2: "h", 3: "w"}}, opset_version=17)` gives an equivalent file.

Usage (from the repository root; installs nothing but into its own venv):
  scripts/make_vintagify_onnx.sh            # downloads vintagify's wheel, writes .style/vintagify.onnx
  python3 scripts/make_vintagify_onnx.py --pth G.pth --out g.onnx [--check-torch]
"""

import argparse
import importlib.util
import io
import pickle
import zipfile

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

OPSET = 17

# The storage classes a state dict names, and their numpy types.
STORAGE_DTYPES = {
    "FloatStorage": np.float32,
    "DoubleStorage": np.float64,
    "HalfStorage": np.float16,
    "LongStorage": np.int64,
    "IntStorage": np.int32,
}


class StorageRef:
    def __init__(self, dtype, key):
        self.dtype = dtype
        self.key = key


def read_state_dict(path):
    """The state dict of a PyTorch zip checkpoint as {name: np.ndarray}, without torch."""
    with zipfile.ZipFile(path) as z:
        names = z.namelist()
        pkl = next(n for n in names if n.endswith("/data.pkl"))
        prefix = pkl[: -len("data.pkl")]
        byteorder = z.read(prefix + "byteorder").decode() if prefix + "byteorder" in names else "little"
        if byteorder != "little":
            raise SystemExit(f"{path}: storages are {byteorder}-endian; only little-endian is read")
        storages = {}

        def storage(ref):
            if ref.key not in storages:
                raw = z.read(f"{prefix}data/{ref.key}")
                storages[ref.key] = np.frombuffer(raw, dtype=ref.dtype)
            return storages[ref.key]

        def rebuild_tensor(ref, offset, size, stride, *_):
            flat = storage(ref)
            item = flat.itemsize
            return np.lib.stride_tricks.as_strided(
                flat[offset:], shape=tuple(size), strides=tuple(s * item for s in stride)
            ).copy()

        class Restricted(pickle.Unpickler):
            def find_class(self, module, name):
                if module == "collections" and name == "OrderedDict":
                    import collections

                    return collections.OrderedDict
                if module == "torch._utils" and name == "_rebuild_tensor_v2":
                    return rebuild_tensor
                if module == "torch" and name in STORAGE_DTYPES:
                    return STORAGE_DTYPES[name]
                raise pickle.UnpicklingError(f"{path}: refusing global {module}.{name}")

            def persistent_load(self, pid):
                kind, dtype, key, _location, _numel = pid
                if kind != "storage":
                    raise pickle.UnpicklingError(f"{path}: unknown persistent id {kind!r}")
                return StorageRef(dtype, key)

        state = Restricted(io.BytesIO(z.read(pkl))).load()
    return {k: np.ascontiguousarray(v) for k, v in state.items()}


class Graph:
    def __init__(self, state, affine_norm):
        self.state = state
        self.used = set()
        self.nodes = []
        self.inits = []
        self.n = 0
        self.affine_norm = affine_norm

    def param(self, name):
        if name not in self.state:
            raise SystemExit(f"state dict has no {name!r}: not a CycleGAN ResnetGenerator?")
        self.used.add(name)
        if name not in {i.name for i in self.inits}:
            self.inits.append(numpy_helper.from_array(self.state[name].astype(np.float32), name))
        return name

    def const(self, arr):
        self.n += 1
        name = f"const_{self.n}"
        self.inits.append(numpy_helper.from_array(arr, name))
        return name

    def node(self, op, inputs, out=None, **attrs):
        self.n += 1
        out = out or f"{op.lower()}_{self.n}"
        self.nodes.append(helper.make_node(op, inputs, [out], name=f"n{self.n}_{op}", **attrs))
        return out

    def pad(self, x, p):
        return self.node("Pad", [x, self.const(np.array([0, 0, p, p, 0, 0, p, p], np.int64))], mode="reflect")

    def conv(self, x, layer, stride=1, pad=0):
        w = self.param(f"{layer}.weight")
        k = self.state[w].shape[2]
        return self.node(
            "Conv", [x, w, self.param(f"{layer}.bias")], kernel_shape=[k, k], strides=[stride] * 2, pads=[pad] * 4
        )

    def conv_t(self, x, layer):
        w = self.param(f"{layer}.weight")
        k = self.state[w].shape[2]
        return self.node(
            "ConvTranspose",
            [x, w, self.param(f"{layer}.bias")],
            kernel_shape=[k, k],
            strides=[2, 2],
            pads=[1, 1, 1, 1],
            output_padding=[1, 1],
        )

    def norm(self, x, layer, channels):
        if self.affine_norm:
            scale, bias = self.param(f"{layer}.weight"), self.param(f"{layer}.bias")
        else:
            scale = self.const(np.ones(channels, np.float32))
            bias = self.const(np.zeros(channels, np.float32))
        return self.node("InstanceNormalization", [x, scale, bias], epsilon=1e-5)

    def relu(self, x):
        return self.node("Relu", [x])


def build(state, affine_norm=True):
    """The ONNX model of a CycleGAN ResnetGenerator state dict (layout in the module doc)."""
    g = Graph(state, affine_norm)
    ch = lambda layer: state[f"{layer}.weight"].shape[0]  # noqa: E731
    x = g.pad("input", 3)
    x = g.relu(g.norm(g.conv(x, "model.1"), "model.2", ch("model.1")))
    x = g.relu(g.norm(g.conv(x, "model.4", stride=2, pad=1), "model.5", ch("model.4")))
    x = g.relu(g.norm(g.conv(x, "model.7", stride=2, pad=1), "model.8", ch("model.7")))
    k = 10
    while f"model.{k}.block.1.weight" in state:
        b = f"model.{k}.block"
        y = g.relu(g.norm(g.conv(g.pad(x, 1), f"{b}.1"), f"{b}.2", ch(f"{b}.1")))
        y = g.norm(g.conv(g.pad(y, 1), f"{b}.5"), f"{b}.6", ch(f"{b}.5"))
        x = g.node("Add", [x, y])
        k += 1
    for _ in range(2):
        out_ch = state[f"model.{k}.weight"].shape[1]  # ConvTranspose weights are [in, out, k, k]
        x = g.relu(g.norm(g.conv_t(x, f"model.{k}"), f"model.{k + 1}", out_ch))
        k += 3
    x = g.conv(g.pad(x, 3), f"model.{k + 1}")
    g.node("Tanh", [x], out="output")
    unused = sorted(set(state) - g.used)
    if unused:
        raise SystemExit(f"state dict entries not used by the ResnetGenerator layout: {unused[:5]}")
    dims = ["n", 3, "h", "w"]
    graph = helper.make_graph(
        g.nodes,
        "cyclegan_resnet_generator",
        [helper.make_tensor_value_info("input", TensorProto.FLOAT, dims)],
        [helper.make_tensor_value_info("output", TensorProto.FLOAT, dims)],
        g.inits,
    )
    model = helper.make_model(
        graph, opset_imports=[helper.make_opsetid("", OPSET)], producer_name="panoconv/scripts/make_vintagify_onnx.py"
    )
    model.ir_version = 8
    onnx.checker.check_model(model)
    return model


def check_against_torch(pth, onnx_path, vintagify_dir):
    """Compares the ONNX model (onnxruntime) with vintagify's own PyTorch module on one input."""
    import onnxruntime as ort
    import torch

    # generator.py alone: the package's __init__ pulls in its training and plotting imports.
    spec = importlib.util.spec_from_file_location("generator", f"{vintagify_dir}/vintagify/generator.py")
    generator = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(generator)
    net = generator.ResnetGenerator()
    net.load_state_dict(torch.load(pth, map_location="cpu"))
    net.eval()
    x = np.random.default_rng(7).uniform(-1, 1, (1, 3, 128, 192)).astype(np.float32)
    with torch.no_grad():
        want = net(torch.from_numpy(x)).numpy()
    got = ort.InferenceSession(onnx_path, providers=["CPUExecutionProvider"]).run(None, {"input": x})[0]
    err = float(np.abs(got - want).max())
    print(f"max |onnx - torch| = {err:.3g} over {want.size} values (output range [-1, 1])")
    return err


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pth", required=True, help="PyTorch state dict (zip checkpoint)")
    ap.add_argument("--out", required=True, help="ONNX file to write")
    ap.add_argument("--no-affine-norm", action="store_true", help="InstanceNorm without weights")
    ap.add_argument(
        "--check-torch",
        metavar="VINTAGIFY_DIR",
        help="also compare with vintagify's PyTorch module (needs torch and onnxruntime)",
    )
    args = ap.parse_args()
    state = read_state_dict(args.pth)
    params = sum(v.size for v in state.values())
    model = build(state, affine_norm=not args.no_affine_norm)
    onnx.save(model, args.out)
    print(f"{args.out}: {len(state)} tensors, {params / 1e6:.2f} M parameters, {len(model.graph.node)} nodes")
    if args.check_torch:
        err = check_against_torch(args.pth, args.out, args.check_torch)
        if err > 1e-4:
            raise SystemExit(f"ONNX and PyTorch differ by {err:.3g}")


if __name__ == "__main__":
    main()
