"""A spectral material library: many BRDF files factored into one folder (issue 20).

``build.build_library`` finds every MERL ``.binary``, RGL ``.bsdf`` and project ``.npz``
under the sources, factors each on a process pool or a Dask cluster
(``executors``), and writes one entry per material (``layout``): its factor packs, a
report row and a thumbnail (``thumbnail``), then the library's index (``index``).
Only the process that builds writes: workers return bytes, so a worker that dies
loses nothing, and a task run twice is written once. Every write is atomic, so the
folder is a consistent library whenever the build stops. The Blender side
(``blender/library``) turns a library into an Asset Library .blend.
"""
