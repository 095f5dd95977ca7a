"""Small helpers that the panels and operators of several capabilities share."""

from __future__ import annotations


def active_material(context):
    """The active object's active material, or None."""
    obj = context.active_object
    return obj.active_material if obj is not None else None


def draw_image(layout, image, scale: float) -> None:
    """An image datablock's preview (a plot), if there is one."""
    if image is None:
        return
    image.preview_ensure()
    layout.template_icon(icon_value=image.preview.icon_id, scale=scale)
