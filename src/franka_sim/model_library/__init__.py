"""The robot's model library: its kinematics as a shared library, for the clients that ask for
one (libfranka before 0.18 sends LoadModelLibrary and loads what it gets)."""

from .build import ModelLibrary

__all__ = ["ModelLibrary"]
