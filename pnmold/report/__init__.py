"""What a person reads after a build: ``report.json`` (:mod:`.build_report`), the page
``report.html`` (:mod:`.html`) with its pictures (:mod:`.render`), the FE's files and figures
(:mod:`.fem`) and the fabrication checklist (:mod:`.checklist`). The page shell of :mod:`.html`
serves the diagnosis report too."""
