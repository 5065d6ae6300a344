"""Assembly: the hi-fi bundle's force families in two concurrent lanes, and band-storage
scatter of two-node elements."""
