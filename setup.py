"""Build hook: the top-level ``templates/`` (the layout users know) also goes into the wheel, as
``pnmold/templates/``, where :func:`pnmold.design.templates_dir` finds it when no source
checkout is beside the package. Every other setting is in ``pyproject.toml``."""

from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

TEMPLATES = Path(__file__).resolve().parent / "templates"


class BuildPyWithTemplates(build_py):
    """``build_py``, then ``templates/**/*.toml`` copied to ``<build_lib>/pnmold/templates/``."""

    def run(self) -> None:
        super().run()
        if self.editable_mode:  # an editable install reads templates/ in the checkout
            return
        target = Path(self.build_lib) / "pnmold" / "templates"
        for source in sorted(TEMPLATES.rglob("*.toml")):
            dest = target / source.relative_to(TEMPLATES)
            self.mkpath(str(dest.parent))
            self.copy_file(str(source), str(dest))


setup(cmdclass={"build_py": BuildPyWithTemplates})
