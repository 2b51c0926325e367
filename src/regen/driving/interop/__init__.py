"""Files other simulators load and files they wrote, both ways: the Scenic program, OpenSCENARIO
with its OpenDRIVE map (written, and read back by ``regen import``), the
paper's config form.

Imports: ``world``, ``primitives`` and ``simulation`` of this domain and the shared core.
"""
