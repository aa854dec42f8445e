"""The controller that goes out to hardware: digital sections, implementation costs, export.

* :mod:`robrst.controller.digital` — the Tustin controller as second-order sections, and
  its exact response;
* :mod:`robrst.controller.implementation` — what a float32/float64 implementation of those
  sections costs on the sampled loop;
* :mod:`robrst.controller.export` — the exported record (:class:`ExportedController`), with
  its JSON, C (:mod:`robrst.controller.c_code`) and Python
  (:mod:`robrst.controller.python_code`) writers.
"""
