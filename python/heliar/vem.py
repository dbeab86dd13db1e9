"""Captured video environment maps as directional lights (Havran et al. 2005): see
:class:`Decomposer`."""

from ._heliar import Decomposer  # noqa: F401

__all__ = ["Decomposer"]
