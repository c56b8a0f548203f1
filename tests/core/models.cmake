# Tests of the models.
