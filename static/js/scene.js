import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { RoomEnvironment } from 'three/addons/environments/RoomEnvironment.js';

// The robot data is Z up (metres); make every camera and light agree.
THREE.Object3D.DEFAULT_UP.set( 0, 0, 1 );

const _box = new THREE.Box3();
const _size = new THREE.Vector3();
const _centre = new THREE.Vector3();
const _offset = new THREE.Vector3();

/**
 * Renderer, orbit camera, lights, floor grid and shadows: everything in the view
 * that is not a robot. Robots are added under `world`.
 */
class Stage {

	constructor( container ) {

		this.container = container;

		this.renderer = new THREE.WebGLRenderer( { antialias: true, alpha: true } );
		this.renderer.setPixelRatio( Math.min( window.devicePixelRatio, 2 ) );
		this.renderer.toneMapping = THREE.NeutralToneMapping;
		this.renderer.shadowMap.enabled = true;
		this.renderer.shadowMap.type = THREE.PCFShadowMap;
		container.appendChild( this.renderer.domElement );

		this.scene = new THREE.Scene();
		// Soft image-based light from a neutral room; the room is Y up, so turn it to Z up.
		this.pmrem = new THREE.PMREMGenerator( this.renderer );
		const room = new RoomEnvironment();
		this.environment = this.pmrem.fromScene( room, 0.04 ).texture;
		room.dispose();
		this.scene.environment = this.environment;
		this.scene.environmentIntensity = 0.4;
		this.scene.environmentRotation.set( Math.PI / 2, 0, 0 );

		this.camera = new THREE.PerspectiveCamera( 40, 1, 0.01, 100 );
		this.camera.position.set( 1.6, - 2.2, 1.4 );

		this.controls = new OrbitControls( this.camera, this.renderer.domElement );
		this.controls.target.set( 0, 0, 0.3 );
		this.controls.enableDamping = true;
		this.controls.dampingFactor = 0.1;
		this.controls.maxPolarAngle = Math.PI * 0.495;
		this.controls.update();

		this._addLights();
		this._addFloor();

		this.world = new THREE.Group();
		this.world.name = 'world';
		this.scene.add( this.world );

		this._onResize = () => this.resize();
		window.addEventListener( 'resize', this._onResize );
		this.resize();

	}

	_addLights() {

		const hemi = new THREE.HemisphereLight( 0xf4f6ff, 0x8a8f99, 0.6 );
		this.scene.add( hemi );

		const sun = new THREE.DirectionalLight( 0xffffff, 1.9 );
		sun.position.set( 2.5, - 1.5, 4.0 );
		sun.castShadow = true;
		sun.shadow.mapSize.set( 2048, 2048 );
		sun.shadow.bias = - 0.0004;
		sun.shadow.normalBias = 0.01;
		sun.shadow.radius = 3;
		this.scene.add( sun );
		this.scene.add( sun.target );
		this.sun = sun;

		const fill = new THREE.DirectionalLight( 0xdde6ff, 0.5 );
		fill.position.set( - 3, 2, 1.5 );
		this.scene.add( fill );

	}

	_addFloor() {

		const floor = new THREE.Mesh(
			new THREE.PlaneGeometry( 40, 40 ),
			new THREE.ShadowMaterial( { color: 0x1d2430, opacity: 0.18, depthWrite: false } )
		);
		floor.receiveShadow = true;
		floor.renderOrder = - 2;
		this.scene.add( floor );
		this.floor = floor;

		// GridHelper lies in XZ; the floor here is the XY plane.
		const grid = new THREE.GridHelper( 8, 32, 0x9aa1ab, 0xc6cbd2 );
		grid.rotation.x = Math.PI / 2;
		grid.material.transparent = true;
		grid.material.opacity = 0.7;
		grid.material.depthWrite = false;
		grid.renderOrder = - 1; // lines over the floor shadow (renderOrder - 2)
		this.scene.add( grid );
		this.grid = grid;

	}

	/** Point the camera (and the sun's shadow frustum) at everything under `world`. */
	frameWorld() {

		_box.setFromObject( this.world );
		if ( _box.isEmpty() ) return;

		_box.getSize( _size );
		_box.getCenter( _centre );
		const radius = Math.max( _size.length() / 2, 0.3 );
		const fov = THREE.MathUtils.degToRad( this.camera.fov );
		const distance = radius / Math.sin( fov / 2 );
		_offset.set( 0.55, - 0.75, 0.45 ).normalize().multiplyScalar( distance );
		this.controls.target.copy( _centre );
		this.camera.position.copy( _centre ).add( _offset );
		this.camera.near = distance / 100;
		this.camera.far = distance * 20;
		this.camera.updateProjectionMatrix();
		this.controls.update();

		// Fit the sun's shadow frustum around the robots.
		const shadow = this.sun.shadow.camera;
		const half = radius * 1.3;
		shadow.left = - half;
		shadow.right = half;
		shadow.top = half;
		shadow.bottom = - half;
		shadow.near = 0.1;
		shadow.far = 10 + radius * 4;
		this.sun.target.position.copy( _centre );
		this.sun.position.copy( _centre ).add( _offset.set( 2.5, - 1.5, 4.0 ) );
		shadow.updateProjectionMatrix();

	}

	resize() {

		const width = this.container.clientWidth || window.innerWidth;
		const height = this.container.clientHeight || window.innerHeight;
		this.camera.aspect = width / height;
		this.camera.updateProjectionMatrix();
		this.renderer.setSize( width, height, false );

	}

	render() {

		this.controls.update();
		this.renderer.render( this.scene, this.camera );

	}

	dispose() {

		window.removeEventListener( 'resize', this._onResize );
		this.renderer.setAnimationLoop( null );
		this.controls.dispose();
		this.floor.geometry.dispose();
		this.floor.material.dispose();
		this.grid.dispose();
		this.environment.dispose();
		this.pmrem.dispose();
		this.renderer.dispose();
		this.renderer.domElement.remove();

	}

}

export { Stage };
