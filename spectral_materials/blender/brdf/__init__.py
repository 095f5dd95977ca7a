"""Factor-pack materials in Blender: sources, scene analysis, jobs, storage on images, the
GPU material and the 5 nm reference image."""
