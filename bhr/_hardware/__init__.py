"""The hardware: what the nitinol wires sustain (:mod:`~bhr._hardware.thermal`), the serial protocol
(:mod:`~bhr._hardware.protocol`), the link to the actuator board (:mod:`~bhr._hardware.link`) and the firmware
header generated from the code table (:mod:`~bhr._hardware.firmware_header`).

Imports the model, the settings and the kernels below it; studies and output build on it.
"""
