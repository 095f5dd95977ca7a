"""Blender's ``gpu`` module made usable here: the (headless) context, shader assembly from
``glsl/``, the pipeline state every draw sets, the display uniforms, float textures, model
matrices, the evaluated-mesh readers, mesh batches and offscreen targets. Nothing here
knows a capability."""
