"""Vision: the camera model, calibration boards seen and detected, and the camera's calibration
(intrinsics, hand-eye, the board in the world) from views (``docs/vision.md``).

Plain data in (``model.vision``), plain results out; OpenCV (``cv2``) is imported only by the
functions that detect corners or give the closed-form start, never at import.
"""
