"""Gymnasium environments (registered as ``mjchar/...``)."""
