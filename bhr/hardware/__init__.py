"""The hardware: what the nitinol wires sustain (:mod:`~bhr.hardware.thermal`), the serial protocol
(:mod:`~bhr.hardware.protocol`), the link to the actuator board (:mod:`~bhr.hardware.link`) and the firmware
header generated from the code table (:mod:`~bhr.hardware.firmware_header`).

Imports the model, the settings and the kernels below it; studies and output build on it.
"""
