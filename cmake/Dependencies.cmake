# Every external dependency is found here, once. All are Debian 12 packages installed by
# scripts/setup.sh.
find_package(Threads REQUIRED)
find_package(OpenCV 4 REQUIRED COMPONENTS core imgproc imgcodecs features2d calib3d flann)
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
# JPEG and PNG through their own libraries (common/image): libturbojpeg0-dev, libpng-dev.
find_package(PkgConfig REQUIRED)
pkg_check_modules(TurboJpeg REQUIRED IMPORTED_TARGET libturbojpeg)
find_package(PNG REQUIRED)
find_package(spdlog REQUIRED)
find_package(yaml-cpp REQUIRED)
find_package(CLI11 REQUIRED)
# The server's wire: Protobuf 3.21 (libprotobuf-dev, protobuf-compiler) and cppzmq 4.9 over
# libzmq 4.3 (cppzmq-dev ships a CMake config that finds libzmq through pkg-config).
find_package(Protobuf REQUIRED)
find_package(cppzmq REQUIRED)
# The server's operator endpoint: prometheus-cpp 1.0's core (metrics and their text format;
# prometheus-cpp-dev) and civetweb 1.15 (its HTTP server; libcivetweb-dev).
find_package(prometheus-cpp CONFIG REQUIRED)
find_package(civetweb CONFIG REQUIRED)
if(SCENELOC_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
if(SCENELOC_BUILD_BENCHMARKS)
  find_package(benchmark REQUIRED)
endif()

# OpenCV's CMake config exports plain variables; wrap them in imported targets so our
# targets can link them PRIVATE or PUBLIC like any other. sceneloc_opencv is what the
# installed programs may link: not imgcodecs, whose Debian package pulls in GDAL, HDF5 and
# poppler (images go through common/image). Tests, benchmarks and fuzz seeds use imgcodecs
# as the reference the codec is checked against: sceneloc_opencv_imgcodecs.
add_library(sceneloc_opencv INTERFACE)
target_include_directories(sceneloc_opencv SYSTEM INTERFACE ${OpenCV_INCLUDE_DIRS})
target_link_libraries(sceneloc_opencv INTERFACE opencv_core opencv_imgproc opencv_features2d
                                                opencv_calib3d opencv_flann)
add_library(sceneloc_opencv_imgcodecs INTERFACE)
target_link_libraries(sceneloc_opencv_imgcodecs INTERFACE sceneloc_opencv opencv_imgcodecs)
find_package(nlohmann_json 3 REQUIRED)
