"""jackson_bringup as an ament_python package: ``colcon build`` installs the launch file, the
URDF and the parameter files under share/jackson_bringup and ``mcu_clock`` under
lib/jackson_bringup (for ``ros2 run``)."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = "jackson_bringup"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/launch", glob("launch/*.launch.py")),
        (f"share/{PACKAGE}/urdf", glob("urdf/*.urdf")),
        (f"share/{PACKAGE}/config", glob("config/*.yaml")),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="Jackson maintainers",
    maintainer_email="maintainers@jackson-ugv.org",
    description="The Jackson UGV's URDF, bringup launch file and Nav2 / slam_toolbox parameters",
    license="MIT",
    entry_points={"console_scripts": [f"mcu_clock = {PACKAGE}.mcu_clock:main"]},
)
