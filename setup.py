"""Build hook: the top-level ``templates/`` and ``docs/`` (the layout users know) also go into the
wheel, as ``pnmold/templates/`` and ``pnmold/docs/``, where :func:`pnmold.design.templates_dir` and
``pnmold docs`` find them when no source checkout is beside the package. Every other setting is in
``pyproject.toml``."""

from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent
#: top-level folder -> the files of it the wheel carries inside the package
SHIPPED = {"templates": "*.toml", "docs": "*.md"}


class BuildPyWithTemplates(build_py):
    """``build_py``, then ``templates/**/*.toml`` and ``docs/**/*.md`` copied into ``<build_lib>/pnmold/``."""

    def run(self) -> None:
        super().run()
        if self.editable_mode:  # an editable install reads templates/ and docs/ in the checkout
            return
        for folder, pattern in SHIPPED.items():
            source_dir = ROOT / folder
            target = Path(self.build_lib) / "pnmold" / folder
            for source in sorted(source_dir.rglob(pattern)):
                dest = target / source.relative_to(source_dir)
                self.mkpath(str(dest.parent))
                self.copy_file(str(source), str(dest))


setup(cmdclass={"build_py": BuildPyWithTemplates})
