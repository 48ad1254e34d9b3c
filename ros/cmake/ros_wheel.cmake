# Shared by the interface packages under ros/: build ROS 2 interfaces against the ROS wheels
# from PyPI (no ROS installation, no colcon).
find_package(Python3 REQUIRED COMPONENTS Interpreter Development.Module NumPy)

# The ROS wheels put their CMake packages under <prefix>/share, where <prefix> is the
# environment that holds them (pip's isolated build environment, or the target environment).
execute_process(
  COMMAND "${Python3_EXECUTABLE}" -c
    "import sys, pathlib, ament_package; print(pathlib.Path(ament_package.__file__).resolve().parents[4]); print(sys.prefix)"
  OUTPUT_VARIABLE _ros_prefixes OUTPUT_STRIP_TRAILING_WHITESPACE COMMAND_ERROR_IS_FATAL ANY)
string(REPLACE "\n" ";" _ros_prefixes "${_ros_prefixes}")
list(REMOVE_DUPLICATES _ros_prefixes)
list(PREPEND CMAKE_PREFIX_PATH ${_ros_prefixes})
string(REPLACE ";" ":" _ament_path "${_ros_prefixes}")
set(ENV{AMENT_PREFIX_PATH} "${_ament_path}")

find_package(ament_cmake REQUIRED)
find_package(rosidl_default_generators REQUIRED)

# The wheels' exported *__rosidl_generator_py targets name the include folders of the machine
# that built them: point them at this Python's and numpy's.
macro(ros_wheel_fix_python_targets)
  get_property(_targets DIRECTORY PROPERTY IMPORTED_TARGETS)
  foreach(_t IN LISTS _targets)
    if(_t MATCHES "__rosidl_generator_py$")
      set_target_properties(${_t} PROPERTIES
        INTERFACE_INCLUDE_DIRECTORIES "${Python3_INCLUDE_DIRS};${Python3_NumPy_INCLUDE_DIRS}")
    endif()
  endforeach()
endmacro()
