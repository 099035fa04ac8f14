"""identify: crash-test recordings in, collision-model parameters out.

The glue between ``video`` (film -> measured motion) and ``sim`` (the collision model):
reading recordings, fitting, results and the command line (``identify.cli``).

    import identify
    ident = identify.fit("crash.mp4", "audi_a4")      # what `identify fit` does
    ident.parameters["k_compression"]                 # {"value": ..., "unit": ..., "std": ...}
"""

from identify.errors import UserError as UserError
from identify.identification import Identification as Identification, fit as fit
from identify.measurement import Measurement as Measurement
from identify.recording import load_recording as load_recording
