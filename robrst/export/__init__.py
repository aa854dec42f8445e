"""Export of the digital controller: the record, and its JSON, C and Python writers."""

from robrst.export.c_code import c_files
from robrst.export.core import ExportedController, export_controller
from robrst.export.python_code import python_module

__all__ = ["ExportedController", "export_controller", "c_files", "python_module"]
