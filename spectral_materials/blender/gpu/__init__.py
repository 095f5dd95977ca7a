"""Blender's ``gpu`` module made usable here: the (headless) context, shader assembly from
``glsl/``, the pipeline state every draw sets, mesh batches and offscreen targets."""
