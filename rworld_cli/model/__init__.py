"""Plain SI data with no file knowledge: the cell (frames, objects, sensors, devices, features,
affixments, conditions), the hierarchy rules, programs and runs, measurements, paths.

Everything that computes sits above this room; the file formats (``schema/``) build these objects.
"""
