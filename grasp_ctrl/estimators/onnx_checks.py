"""Checks of an ONNX policy file against its metadata (docs/design.md 5.5), before and after loading.

- ``model_sha256``: the model file's SHA-256 must equal the metadata's; checked before
  onnxruntime parses the file, so a swapped or corrupted model never runs.
- graph I/O: every input and output tensor named in the metadata must exist in the
  graph with the same rank, the same fixed dimensions (symbolic ones such as the
  batch match any symbolic name) and the same element type; the graph must not need
  inputs the metadata does not describe.
Errors are :class:`PolicyError` naming the file and the field.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from grasp_ctrl.errors import PolicyError
from grasp_ctrl.files.storage import file_sha256

SHA256_HEX = re.compile(r"^[0-9a-f]{64}$")
# metadata dtype -> onnxruntime's type string
ORT_TYPES = {
    "float32": "tensor(float)",
    "float64": "tensor(double)",
    "float16": "tensor(float16)",
    "int64": "tensor(int64)",
    "int32": "tensor(int32)",
    "bool": "tensor(bool)",
}


def verify_model_hash(meta: dict[str, Any], json_path: Path, model_file: Path) -> None:
    want = meta.get("model_sha256")
    if want is None:
        raise PolicyError(f"{json_path}: model_sha256: required key is missing (the SHA-256 of {model_file.name})")
    if not isinstance(want, str) or not SHA256_HEX.match(want.lower()):
        raise PolicyError(f"{json_path}: model_sha256: 64 hexadecimal digits expected (got {want!r})")
    got = file_sha256(model_file)
    if got != want.lower():
        raise PolicyError(
            f"{json_path}: model_sha256: {model_file.name} has SHA-256 {got}, the metadata says {want} "
            "(model file replaced or corrupted)"
        )


def _shape_ok(want: list[Any], got: list[Any]) -> bool:
    if len(want) != len(got):
        return False
    for w, g in zip(want, got):
        if isinstance(w, int) and not isinstance(w, bool):
            if g != w:
                return False
        elif isinstance(g, int) and not isinstance(g, bool):  # metadata symbolic, graph fixed
            return False
    return True


def _check_tensors(json_path: Path, section: str, declared: Any, graph: dict[str, Any], all_required: bool) -> None:
    if not isinstance(declared, dict) or not declared:
        raise PolicyError(f"{json_path}: {section}: a table of tensor names expected")
    for name, spec in declared.items():
        where = f"{json_path}: {section}.{name}"
        if name not in graph:
            kind = "input" if section.startswith("input") else "output"
            raise PolicyError(
                f"{json_path}: {section}: {name!r} is not an {kind} of the ONNX model (it has {sorted(graph)})"
            )
        if not isinstance(spec, dict):
            raise PolicyError(f"{where}: a table with shape and dtype expected")
        node = graph[name]
        shape = spec.get("shape")
        if shape is not None:
            if not isinstance(shape, list):
                raise PolicyError(f"{where}.shape: a list expected (got {shape!r})")
            if not _shape_ok(shape, list(node.shape)):
                raise PolicyError(f"{where}.shape: metadata says {shape}, the ONNX model has {list(node.shape)}")
        dtype = spec.get("dtype")
        if dtype is not None:
            if dtype not in ORT_TYPES:
                raise PolicyError(f"{where}.dtype: one of {', '.join(ORT_TYPES)} (got {dtype!r})")
            if ORT_TYPES[dtype] != node.type:
                raise PolicyError(f"{where}.dtype: metadata says {dtype}, the ONNX model has {node.type}")
    if all_required:
        undeclared = sorted(set(graph) - set(declared))
        if undeclared:
            raise PolicyError(f"{json_path}: {section}: the ONNX model also needs {undeclared}, not in the metadata")


def check_graph_io(session: Any, meta: dict[str, Any], json_path: Path) -> None:
    """The loaded graph's inputs and outputs against ``input.tensors`` and ``output.tensors``."""
    inputs = {i.name: i for i in session.get_inputs()}
    outputs = {o.name: o for o in session.get_outputs()}
    _check_tensors(json_path, "input.tensors", (meta.get("input") or {}).get("tensors"), inputs, all_required=True)
    _check_tensors(json_path, "output.tensors", (meta.get("output") or {}).get("tensors"), outputs, all_required=False)
