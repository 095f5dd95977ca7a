"""The demo (the main job): one module per section, run by ``demos.main``.

``scene`` builds the demo scene; ``brdf`` the factor-pack figures; ``gpu_draw``, ``eevee``,
``prt`` and ``btf`` the other sections; ``report`` writes report.md; ``sizes`` holds the
full and the quick sizes. Entry points: ``scripts/demo [--quick]``, ``python -m demos``.
"""
