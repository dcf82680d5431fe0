"""bn/io."""
