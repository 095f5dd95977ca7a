"""Writing UBO2014-layout files (for tests and small synthetic BTFs)."""

from __future__ import annotations

import io
import struct
from pathlib import Path

import numpy as np

from .._files import atomic_write
from .ubo2014_stream import _DTYPES, _SIGNATURES


def _pack_text(text: str, size: int = 80) -> bytes:
    data = text.encode("latin-1")[: size - 1]
    return data + b"\0" * (size - len(data))


def _pack_header(version: int, channels: list, xml: str, cosine_flag: int,
                 measurement_setup: str, image_sensor: str, light_source: str, ppmm: float,
                 rgb_scale) -> bytes:
    """The common header, led by its own byte count (the fields ``version`` has)."""
    body = io.BytesIO()
    body.write(struct.pack("<I", int(version)))
    for text in (measurement_setup, image_sensor, light_source):
        body.write(_pack_text(text))
    body.write(struct.pack("<4f", ppmm, *rgb_scale))
    if version > 1:
        body.write(struct.pack("<I", int(cosine_flag)))
    if version > 2:
        data = xml.encode("utf-8")
        body.write(struct.pack("<I", len(data)) + data)
    if version > 3:
        body.write(struct.pack("<I", len(channels)))
        for name in channels:
            data = name.encode("latin-1")
            body.write(struct.pack("<I", len(data)) + data)
    return struct.pack("<I", 4 + body.tell()) + body.getvalue()


def _write_dfmf_factors(out: io.BytesIO, u, sxv, singular_values, channels: list,
                        color_model: int, data_size: int, dtype: np.dtype) -> None:
    """DFMF: the colour model, then one factor block per channel."""
    us = [np.asarray(a) for a in u]
    sxvs = [np.asarray(a) for a in sxv]
    if len(us) != len(channels) or len(sxvs) != len(channels):
        raise ValueError("DFMF needs one U and one S·V array per channel")
    svs = singular_values or [np.ones(a.shape[1]) for a in us]
    out.write(struct.pack("<II", int(us[0].shape[1]), int(color_model)))
    out.write(np.zeros(3, "<f4").tobytes() + np.eye(3, dtype="<f4").tobytes())
    for uc, sc, sv in zip(us, sxvs, svs, strict=True):
        k = uc.shape[1]
        out.write(struct.pack("<BIII", int(data_size), k, uc.shape[0], sc.shape[0]))
        for block in (sv, uc, sc):
            out.write(np.ascontiguousarray(block, dtype=dtype).tobytes())


def _write_fmf_factors(out: io.BytesIO, signature: str, u, sxv, singular_values,
                       dynamic_range_reduction: bool, height_map: np.ndarray | None,
                       data_size: int, dtype: np.dtype) -> None:
    """FMF0/FMF1: (FMF1: extension version 2) one factor block shared by the channels."""
    if signature == "FMF1":
        out.write(struct.pack("<BI", 2, int(bool(dynamic_range_reduction))))
        hm = np.zeros((0, 0), "<u2") if height_map is None \
            else np.asarray(height_map, "<u2")
        out.write(struct.pack("<II", hm.shape[1], hm.shape[0]) + hm.tobytes())
    u = np.asarray(u).reshape(-1, np.shape(u)[-1])
    sxv = np.asarray(sxv)
    k = u.shape[1]
    sv = np.ones(k) if singular_values is None else np.asarray(singular_values)
    out.write(struct.pack("<IBI", k, int(data_size), k))
    out.write(struct.pack("<II", u.shape[0], sxv.shape[0]))
    for block in (sv, u, sxv):
        out.write(np.ascontiguousarray(block, dtype=dtype).tobytes())


def write_ubo2014(path: str | Path, *, view_angles: np.ndarray, light_angles: np.ndarray,
                  width: int, height: int, u, sxv, singular_values=None,
                  signature: str = "FMF0", data_size: int = 4, version: int = 4,
                  channels=("R", "G", "B"), xml: str = "", cosine_flag: int = 0,
                  rotations: np.ndarray | None = None, color_model: int = 0,
                  dynamic_range_reduction: bool = False,
                  height_map: np.ndarray | None = None, measurement_setup: str = "",
                  image_sensor: str = "", light_source: str = "", ppmm: float = 0.0,
                  rgb_scale=(1.0, 1.0, 1.0)) -> Path:
    """Write a UBO2014-layout file (for tests and small synthetic BTFs).

    Angles are (θ, φ) radians, (V, 2) and (L, 2); every view gets the same light list.
    FMF0/FMF1: ``u`` is (V·L·C, k) (rows ordered view, light, channel) and ``sxv``
    (W·H, k), texels bottom row first; ``singular_values`` (k,) defaults to ones.
    DFMF: ``u`` and ``sxv`` are lists with one (V·L, kc) / (W·H, kc) array per channel and
    ``singular_values`` a list too. ``version`` (1..4) selects the optional header fields.
    FMF1 writes extension version 2 (a height map of 0×0 when ``height_map`` is None).
    """
    path = Path(path)
    if signature not in ("DFMF", "FMF0", "FMF1"):
        raise ValueError(f"signature {signature!r} is not DFMF, FMF0 or FMF1")
    dtype = _DTYPES.get(int(data_size))
    if dtype is None:
        raise ValueError(f"data_size {data_size} is not 2, 4 or 8")
    views = np.asarray(view_angles, dtype="<f4").reshape(-1, 2)
    lights = np.asarray(light_angles, dtype="<f4").reshape(-1, 2)
    channels = list(channels) if version > 3 else ["R", "G", "B"]
    out = io.BytesIO()
    out.write(b"!" + signature.encode() + _SIGNATURES[signature.encode()])
    if rotations is not None:
        out.write(b"R")
    out.write(_pack_header(version, channels, xml, cosine_flag, measurement_setup,
                           image_sensor, light_source, ppmm, rgb_scale))
    out.write(struct.pack("<I", views.shape[0]))
    for view in views:
        out.write(view.tobytes() + struct.pack("<I", lights.shape[0]) + lights.tobytes())
    out.write(struct.pack("<II", int(width), int(height)))
    if rotations is not None:
        rot = np.asarray(rotations, dtype="<f4").reshape(-1, 3, 3)
        out.write(struct.pack("<I", rot.shape[0]) + rot.tobytes())
    if signature == "DFMF":
        _write_dfmf_factors(out, u, sxv, singular_values, channels, color_model, data_size,
                            dtype)
    else:
        _write_fmf_factors(out, signature, u, sxv, singular_values, dynamic_range_reduction,
                           height_map, data_size, dtype)
    return atomic_write(path, lambda handle: handle.write(out.getvalue()))
