# The tiled parallel OctoMap fusion (issue 5): equal to serial insertPointCloud.
graphslam_test(partition/tiled_fusion)
