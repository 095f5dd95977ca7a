"""Colour: spectra and CMFs, the colour pipeline (XYZ, CIELAB, ΔE94, display), spectral
bases (Peercy, the scene basis), RGB→spectrum uplift, metamers and the UI's spectrum library."""
