"""Virtual test campaigns: a catalogue of bundle constructions -> hi-fi virtual tests -> a ROM property library (issue 28)."""
