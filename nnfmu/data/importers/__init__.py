"""Importers for public measured data sets whose files are not nnfmu's CSV/MDF layout."""

from nnfmu.data.importers.brfd import BRFD_LICENCE, load_brfd, load_brfd_series

__all__ = ["BRFD_LICENCE", "load_brfd", "load_brfd_series"]
