"""linkview: a live digital twin of ctrlX-controlled machines in the browser."""
