"""pnmold's FE for other tools: ParaView (:mod:`.vtu`), Abaqus/CalculiX (:mod:`.abaqus`,
:mod:`.calculix`), SOFA (:mod:`.sofa`), constants for solvers without Yeoh (:mod:`.constants`),
a build folder's problem (:mod:`.folder`). Importing the package loads none of them."""

#: ``pnmold export --format``
FORMATS = ("abaqus", "sofa")
#: the deck's dialect of output requests, solid elements and paper elements
SOLVERS = ("calculix", "abaqus")
SOLID_ELEMENTS = ("C3D10", "C3D10H")
LAYER_ELEMENTS = ("M3D6", "S6", "C3D15")
