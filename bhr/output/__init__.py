"""Output: figures (:mod:`~bhr.output.plots`, :mod:`~bhr.output.thermal_plot`), animations and the live view
(:mod:`~bhr.output.animate`, :mod:`~bhr.output.liveview`), HTML pages (:mod:`~bhr.output.htmlpage`) and output
folders written whole or not at all (:mod:`~bhr.output.atomic`).

matplotlib is imported by the figure modules only, when they are used.
"""
