"""Scene format: schema, loader, validation and the case catalog.  Solves nothing."""

from cases.load import CATALOG, CaseError, catalog_names, load, loads, resolve
from cases.schema import Scene

__all__ = ["CATALOG", "CaseError", "Scene", "catalog_names", "load", "loads", "resolve"]
