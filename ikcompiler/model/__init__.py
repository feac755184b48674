"""The kinematic model: an immutable POE chain, its forward kinematics and Jacobians."""

from ikcompiler.model.chain import Chain, Coupling, Joint

__all__ = ["Chain", "Coupling", "Joint"]
