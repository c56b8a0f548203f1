// placeholder: storage helper writes the atomic file writer here
