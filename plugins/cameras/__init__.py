"""Built-in cameras: an OpenCV device, and video / image-folder replay."""
