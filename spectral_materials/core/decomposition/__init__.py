"""Tensor decompositions used by every capability: CP factor packs (alternating least
squares) and separable forms (SVD, normalized decomposition)."""
