"""Three public functions share their names with modules: ``gyrotest.bias``,
``gyrotest.report`` and ``gyrotest.simulate``. Python's import system binds ``gyrotest.report``
to the subpackage whenever any code imports it, so a plain function of that name would be
replaced at random. Instead each of the three modules makes itself callable
(:func:`make_callable`, two lines at its end): ``gyrotest.report(campaign)`` calls :func:`gyrotest.api.campaign.report`,
while ``gyrotest.report.build`` and ``import gyrotest.simulate as S`` keep working. (When the
package layout changes, issue 60, these become plain functions.)

Cheap to import: only ``importlib``, ``sys`` and ``types``.
"""

from __future__ import annotations

import importlib
import sys
import types


class CallableModule(types.ModuleType):
    """A package that is also a function of the public API (module docstring)."""

    def __call__(self, *args, **kwargs):
        mod, name = self.__dict__["__api_function__"]
        return getattr(importlib.import_module(mod), name)(*args, **kwargs)


def make_callable(package: str, function: str, api_module: str = "gyrotest.api.campaign"
                  ) -> None:
    """Make the module ``package`` (a module name) call ``<api_module>.<function>`` when
    called."""
    module = sys.modules[package]
    module.__api_function__ = (api_module, function)
    module.__class__ = CallableModule
