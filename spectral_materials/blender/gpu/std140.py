"""std140 uniform blocks: the GLSL ``struct`` is the one spec, the packer is made from it.

Each parameter block (``glsl/*/…params.glsl``) is declared once, in GLSL, with a comment
per field. :func:`glsl_block` reads that declaration into a :class:`Block`: its fields in
order (name, GLSL type, array length) and their std140 offsets (OpenGL 4.6 §7.6.2.2,
"Standard Uniform Block Layout"). :meth:`Block.pack` writes the values a drawer passes
by field name at those offsets, so a field added, removed, renamed, retyped or moved in
the GLSL is either packed where the shader reads it or refused (a name the block does
not have, or a field without a value): no byte count to keep in step by hand.

Matrices are passed as std140 stores them: column by column (``display.std140_mat4``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .shaders import glsl_source

#: GLSL type → (NumPy element type, columns, rows). A vector is one column, a matN is N.
_TYPES: dict[str, tuple[str, int, int]] = {
    "float": ("<f4", 1, 1), "int": ("<i4", 1, 1), "uint": ("<u4", 1, 1),
    **{f"{p}vec{n}": (t, 1, n) for p, t in (("", "<f4"), ("i", "<i4"), ("u", "<u4"))
       for n in (2, 3, 4)},
    **{f"mat{n}": ("<f4", n, n) for n in (2, 3, 4)},
}


def _round_up(value: int, multiple: int) -> int:
    return -(-value // multiple) * multiple


@dataclass(frozen=True)
class Field:
    """One member of a block: ``type name[length]`` (``length`` 0: not an array)."""

    name: str
    glsl_type: str
    length: int = 0

    def __post_init__(self) -> None:
        if self.glsl_type not in _TYPES:
            raise ValueError(f"std140: unsupported type {self.glsl_type!r} of {self.name!r}")

    @property
    def dtype(self) -> np.dtype:
        return np.dtype(_TYPES[self.glsl_type][0])

    @property
    def shape(self) -> tuple[int, ...]:
        """The value's shape: (length?, columns?, rows?), scalars and vectors unwrapped."""
        _, columns, rows = _TYPES[self.glsl_type]
        inner = (columns, rows) if columns > 1 else ((rows,) if rows > 1 else ())
        return ((self.length,) if self.length else ()) + inner

    def _column(self) -> tuple[int, int]:
        """(base alignment, size) of one column vector (or scalar), before array rules."""
        _, _, rows = _TYPES[self.glsl_type]
        return (4 if rows == 1 else 8 if rows == 2 else 16), 4 * rows

    @property
    def alignment(self) -> int:
        align, _ = self._column()
        _, columns, _ = _TYPES[self.glsl_type]
        # Rules 4, 5 and 6: arrays and matrices align their elements to a vec4.
        return _round_up(align, 16) if self.length or columns > 1 else align

    @property
    def slots(self) -> tuple[int, int, int]:
        """(count, stride, components): the field as ``count`` column vectors ``stride``
        bytes apart, relative to its offset."""
        align, size = self._column()
        _, columns, rows = _TYPES[self.glsl_type]
        count = columns * max(self.length, 1)
        stride = _round_up(align, 16) if count > 1 else size
        return count, stride, rows

    @property
    def size(self) -> int:
        count, stride, rows = self.slots
        if count == 1:
            return 4 * rows
        return _round_up(count * stride, 16)


@dataclass(frozen=True)
class Block:
    """A std140 uniform block: its struct name and fields in declaration order."""

    name: str
    fields: tuple[Field, ...]

    # Cached: pack() runs per material per draw, and the layout never changes.
    @cached_property
    def offsets(self) -> dict[str, int]:
        """Byte offset of each field."""
        out, offset = {}, 0
        for field in self.fields:
            offset = _round_up(offset, field.alignment)
            out[field.name] = offset
            offset += field.size
        return out

    @cached_property
    def size(self) -> int:
        """Bytes of the block: the end of its last field, rounded up to a vec4 (rule 9)."""
        last = self.fields[-1]
        return _round_up(self.offsets[last.name] + last.size, 16)

    def pack(self, **values) -> bytes:
        """The block's bytes from one value per field (by name), zero elsewhere."""
        missing = [f.name for f in self.fields if f.name not in values]
        unknown = sorted(set(values) - {f.name for f in self.fields})
        if missing or unknown:
            raise ValueError(f"{self.name}: values missing for {missing}, "
                             f"not in the block: {unknown}")
        data = bytearray(self.size)
        offsets = self.offsets
        for field in self.fields:
            value = np.asarray(values[field.name], dtype=field.dtype)
            if value.shape != field.shape:
                raise ValueError(f"{self.name}.{field.name} ({field.glsl_type}"
                                 f"{f'[{field.length}]' if field.length else ''}): "
                                 f"shape {value.shape}, expected {field.shape}")
            count, stride, rows = field.slots
            columns = np.ascontiguousarray(value).reshape(count, rows)
            for i in range(count):
                start = offsets[field.name] + i * stride
                data[start:start + 4 * rows] = columns[i].tobytes()
        return bytes(data)


_COMMENTS = re.compile(r"/\*.*?\*/|//[^\n]*", re.DOTALL)
_MEMBER = re.compile(r"^(\w+)\s+(\w+)\s*(?:\[\s*(\d+)\s*\])?$")


def parse_struct(source: str, name: str) -> Block:
    """The ``struct name { … };`` of GLSL ``source`` as a :class:`Block`."""
    code = _COMMENTS.sub(" ", source)
    match = re.search(rf"\bstruct\s+{re.escape(name)}\s*\{{(.*?)\}}\s*;", code, re.DOTALL)
    if match is None:
        raise ValueError(f"no struct {name} in the GLSL source")
    fields = []
    for member in filter(None, (m.strip() for m in match.group(1).split(";"))):
        parsed = _MEMBER.match(" ".join(member.split()))
        if parsed is None:
            raise ValueError(f"struct {name}: cannot read member {member!r}")
        glsl_type, field_name, length = parsed.groups()
        fields.append(Field(field_name, glsl_type, int(length or 0)))
    return Block(name, tuple(fields))


def glsl_block(path: str, name: str) -> Block:
    """The block ``name`` declared in ``glsl/<path>``."""
    return parse_struct(glsl_source(path), name)
