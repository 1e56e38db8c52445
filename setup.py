"""ament_python package definition for gear_phm (layout of `ros2 pkg create`)."""
from glob import glob

from setuptools import find_packages, setup

PACKAGE_NAME = 'gear_phm'

setup(
    name=PACKAGE_NAME,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'bench']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE_NAME]),
        ('share/' + PACKAGE_NAME, ['package.xml']),
        ('share/' + PACKAGE_NAME + '/config', glob('config/*.yaml') + glob('config/*.json')),
        ('share/' + PACKAGE_NAME + '/launch', glob('launch/*.launch.py')),
    ],
    python_requires='>=3.11',
    # Runtime dependencies of everything but the ROS nodes (rclpy and the message packages come
    # from ROS, see package.xml). Ranges: from the tested minor version (.ci/requirements.txt
    # pins the exact versions CI runs) up to the next major one.
    install_requires=[
        'setuptools',
        'filterpy>=2.0,<3',
        'lz4>=4.4,<5',
        'matplotlib>=3.11,<4',
        'mcap>=1.6,<2',
        'numpy>=2.4,<3',
        'PyYAML>=6.0,<7',
        'rosbags>=0.11,<0.12',
        'tqdm>=4.70,<5',
        'zstandard>=0.25,<1',
    ],
    # colcon test runs pytest (not unittest) for a package with pytest among these, as
    # `ros2 pkg create` writes it; setup.cfg's pytest options need the two plugins.
    extras_require={
        'test': ['pytest>=9.0,<10', 'pytest-timeout>=2.4,<3', 'pytest-xdist>=3.8,<4'],
    },
    zip_safe=True,
    maintainer='gear_phm maintainers',
    maintainer_email='gear_phm@example.com',
    description='Gearbox friction estimation and remaining useful life for ROS 2 Jazzy.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'publisher = gear_phm.nodes.publisher:main',
            'estimator = gear_phm.nodes.estimator:main',
            'diagnostics = gear_phm.nodes.diagnostics:main',
            'gear-phm = gear_phm.cli.main:main',
        ],
    },
)
