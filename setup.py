from glob import glob

from setuptools import find_packages, setup

package_name = "garment_sim_ros"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test", "bench"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/config", glob("config/*.yaml")),
        ("share/" + package_name + "/config/joint_maps", glob("config/joint_maps/*.yaml")),
        ("share/" + package_name + "/config/garments", glob("config/garments/*")),
    ],
    package_data={package_name: ["data/*.yaml"]},
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="garment_sim_ros developers",
    description="Real-time garment simulation on a moving character for ROS 2 Jazzy",
    license="Apache-2.0",
    python_requires=">=3.11",
    entry_points={
        "console_scripts": [
            "garment-sim = garment_sim_ros.cli:main",
            "garment_sim_node = garment_sim_ros.ros.node:main",
            "skeleton_player = garment_sim_ros.ros.skeleton_player:main",
        ],
    },
)
