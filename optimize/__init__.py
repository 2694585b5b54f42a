"""Design-optimization runs for jaxchain (``python -m optimize``).

The problems (``optimize.problem``: the default free-form tooth and the ISO 606 box;
``optimize.clearance``: their re-measurement in the clearance-joint chain;
``optimize.timing``, ``optimize.quiet``) are the definitions studies and notebooks may
import to measure the main job's designs; the runner (``optimize.run``) and the command
line (``optimize.__main__``) are the job's own (tests/test_layers.py)."""
