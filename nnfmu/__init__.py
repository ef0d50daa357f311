"""nnfmu: neural-network component models from rig data, shipped as standalone FMI co-simulation FMUs."""

__version__ = "0.1.0"
